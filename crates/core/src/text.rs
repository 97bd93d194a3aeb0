//! Text abba shows that came from elsewhere (a person's name, a file's
//! name, a device's or a profile's name read from an export): which
//! characters show nothing or change how the text around them is shown,
//! and the text with each such character written as its code point.

use std::borrow::Cow;
use unicode_properties::{GeneralCategory, UnicodeGeneralCategory};

/// Characters that show nothing or change how the text around them is
/// shown although their general category alone is not format (Cf): the
/// default-ignorable characters of other categories
/// (DerivedCoreProperties.txt) — the combining grapheme joiner, the
/// Hangul fillers, the Khmer inherent vowels, the Mongolian and the other
/// variation selectors, the tag characters — and the braille blank,
/// which shows as a space; with the format characters the old check
/// named (bidirectional overrides and isolates, zero-width characters,
/// the byte-order mark).
pub fn hidden(c: char) -> bool {
    matches!(
        c,
        '\u{034F}'
            | '\u{115F}'
            | '\u{1160}'
            | '\u{17B4}'
            | '\u{17B5}'
            | '\u{180B}'..='\u{180F}'
            | '\u{200B}'..='\u{200F}'
            | '\u{202A}'..='\u{202E}'
            | '\u{2060}'..='\u{206F}'
            | '\u{2800}'
            | '\u{3164}'
            | '\u{FE00}'..='\u{FE0F}'
            | '\u{FEFF}'
            | '\u{FFA0}'
            | '\u{E0000}'..='\u{E007F}'
            | '\u{E0100}'..='\u{E01EF}'
    )
}

/// True for a character a page writes as its code point: a control
/// character other than the line break, tab and carriage return, a format
/// character (Cf: a right-to-left override, a zero-width space ...) or
/// one of [`hidden`].
pub fn unseen(c: char) -> bool {
    (c.is_control() && !matches!(c, '\n' | '\t' | '\r'))
        || c.general_category() == GeneralCategory::Format
        || hidden(c)
}

/// `text` with every [`unseen`] character written as its code point
/// (`\u{202e}`): a name `evil\u{202E}gpj.csv` read from a file is shown
/// so, never as `evilvsc.jpg`.
pub fn shown(text: &str) -> Cow<'_, str> {
    if !text.chars().any(unseen) {
        return Cow::Borrowed(text);
    }
    let mut out = String::with_capacity(text.len() + 16);
    for c in text.chars() {
        if unseen(c) {
            out.extend(c.escape_unicode());
        } else {
            out.push(c);
        }
    }
    Cow::Owned(out)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn unseen_characters_are_written_as_their_code_points() {
        assert_eq!(shown("evil\u{202E}gpj.csv"), "evil\\u{202e}gpj.csv");
        assert_eq!(shown("a\u{0}b\u{1b}[31m"), "a\\u{0}b\\u{1b}[31m");
        assert_eq!(
            shown("x\u{200B}\u{FE0F}\u{E0041}"),
            "x\\u{200b}\\u{fe0f}\\u{e0041}"
        );
        // Ordinary text, line breaks, accents and other scripts as they are.
        for t in ["Zoë 7.8 mmol/L", "line\nnext\ttab", "Ана", "שלום", "名前"] {
            assert!(matches!(shown(t), Cow::Borrowed(_)), "{t}");
        }
    }
}
