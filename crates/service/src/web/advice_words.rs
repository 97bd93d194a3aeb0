//! The advice's sentences as the pages show them. The advice is worded
//! once (abba-advisor's and abba-store's words, which the CLI prints);
//! where a sentence names a flag of `abba person new` or asks for an
//! import, a person's page says who does it instead (a person has no
//! command line and no import form), and the clinic's page names the
//! command (its new-person form has no such field).

/// Flags of `abba person new` and steps a sentence may name, and each
/// audience's words for them.
const FLAGS: [(&str, &str, &str); 5] = [
    (
        "Import them (or an export that has them) before any basal rate is suggested.",
        "Your clinic can import them (or an export that has them); until then no basal rate is suggested.",
        "Import them (or an export that has them) before any basal rate is suggested.",
    ),
    (
        " For research only, a person created with --allow-closed-loop gets basal suggestions.",
        " Whether basal rates are suggested here is your clinic's decision.",
        " For research only, a person created with `abba person new --allow-closed-loop` gets basal suggestions.",
    ),
    (
        "this person was created with --allow-closed-loop (research only)",
        "your clinic allowed basal suggestions for research only",
        "this person was created with `abba person new --allow-closed-loop` (research only)",
    ),
    (
        "(created with --allow-closed-loop)",
        "(allowed by your clinic)",
        "(created with `abba person new --allow-closed-loop`)",
    ),
    (
        "(meal windows are set when the person is created, --meal-windows)",
        "(your clinic set your meal windows)",
        "(meal windows are set when the person is created: `abba person new --meal-windows`)",
    ),
];

/// `msg` for the person's own pages.
pub fn for_person(msg: &str) -> String {
    FLAGS.iter().fold(msg.to_string(), |m, (cli, person, _)| {
        m.replace(cli, person)
    })
}

/// `msg` for the clinic's page.
pub fn for_clinic(msg: &str) -> String {
    FLAGS.iter().fold(msg.to_string(), |m, (cli, _, clinic)| {
        m.replace(cli, clinic)
    })
}

#[cfg(test)]
mod tests {
    use super::*;
    use abba_advisor::words::{delivery_note, meal_not_seen, NotDesignedFor};

    /// Every sentence of the advice that names a flag, as worded today.
    fn sentences() -> Vec<String> {
        vec![
            delivery_note(NotDesignedFor::Delivery {
                shown: "multiple daily injections",
                allowed: false,
            }),
            delivery_note(NotDesignedFor::Delivery {
                shown: "multiple daily injections",
                allowed: true,
            }),
            meal_not_seen("lunch", "11:00-14:00", 2),
        ]
    }

    #[test]
    fn the_persons_pages_never_ask_the_person_to_import() {
        let s = delivery_note(NotDesignedFor::NoInsulinRecords);
        assert!(s.contains("Import them"), "{s}");
        assert!(for_person(&s).contains("Your clinic can import them"));
        assert_eq!(for_clinic(&s), s);
    }

    #[test]
    fn the_persons_pages_name_no_flag_and_the_clinics_name_the_command() {
        for s in sentences() {
            assert!(s.contains(" --"), "the test's sentence names a flag: {s}");
            let p = for_person(&s);
            assert!(!p.contains("--"), "{p}");
            let c = for_clinic(&s);
            assert!(
                c.matches(" --").count() == c.matches("`abba person new --").count(),
                "{c}"
            );
        }
    }
}
