//! `abba therapy set`: the clinician's change of settings, recorded in the
//! log whether or not a suggestion is open; the advisor starts from it.

use abba_store::NOTICE;
use anyhow::{bail, Context, Result};

/// Arguments of `abba therapy`.
#[derive(clap::Args, Debug)]
pub struct Args {
    #[command(subcommand)]
    command: Command,
}

#[derive(clap::Subcommand, Debug)]
enum Command {
    /// Record new settings, in force from --at (default: now).
    Set(SetArgs),
}

#[derive(clap::Args, Debug)]
struct SetArgs {
    #[command(flatten)]
    who: crate::store_args::PersonArgs,
    /// The basal rate (U/h), or a schedule HH:MM=U_PER_H,... starting at 00:00.
    #[arg(long, value_name = "U_PER_H|SCHEDULE")]
    basal: Option<String>,
    /// Carb ratios of breakfast, lunch, dinner (g/U): B,L,D.
    #[arg(long, value_name = "B,L,D")]
    carb_ratio: Option<String>,
    /// In force from: RFC 3339 (2026-03-02T08:00:00+01:00) or the person's
    /// local time YYYY-MM-DDTHH:MM [default: now]; never in the future.
    #[arg(long, value_name = "TIME")]
    at: Option<String>,
}

/// Parses `0.9` or `00:00=0.8,06:00=1.0`.
fn basal(text: &str) -> Result<Vec<(u32, f64)>> {
    if let Ok(v) = text.trim().parse::<f64>() {
        return Ok(vec![(0, v)]);
    }
    let mut out = Vec::new();
    for part in text.split(',') {
        let (t, v) = part
            .split_once('=')
            .with_context(|| format!("--basal \"{part}\": expected HH:MM=U_PER_H"))?;
        let (h, m) = t
            .trim()
            .split_once(':')
            .with_context(|| format!("--basal \"{t}\": expected HH:MM"))?;
        let (h, m): (u32, u32) = (
            h.parse()
                .with_context(|| format!("--basal \"{t}\": hour"))?,
            m.parse()
                .with_context(|| format!("--basal \"{t}\": minute"))?,
        );
        if h > 23 || m > 59 {
            bail!("--basal \"{t}\": not a time of day");
        }
        let v: f64 = v
            .trim()
            .parse()
            .with_context(|| format!("--basal \"{v}\": not a number"))?;
        out.push((h * 60 + m, v));
    }
    Ok(out)
}

fn set(a: SetArgs) -> Result<()> {
    let mut store = a.who.open()?;
    let p = store.person(&a.who.person)?;
    let at = match &a.at {
        None => None,
        Some(t) => Some(match t.parse::<jiff::Timestamp>() {
            Ok(i) => i,
            Err(_) => t
                .parse::<jiff::civil::DateTime>()
                .with_context(|| format!("--at \"{t}\": expected RFC 3339 or YYYY-MM-DDTHH:MM"))?
                .to_zoned(p.tz.clone())
                .with_context(|| {
                    format!(
                        "--at \"{t}\": not a time in {}",
                        p.tz.iana_name().unwrap_or("?")
                    )
                })?
                .timestamp(),
        }),
    };
    let basal = a.basal.as_deref().map(basal).transpose()?;
    let cr = a
        .carb_ratio
        .as_deref()
        .map(|c| crate::person::carb_ratios("--carb-ratio", c))
        .transpose()?;
    let c = store.set_therapy(&a.who.person, basal, cr, at)?;
    let mut what = Vec::new();
    if let Some(b) = &c.basal {
        let s: Vec<String> = b
            .iter()
            .map(|&(m, r)| format!("{:02}:{:02} {r}", m / 60, m % 60))
            .collect();
        what.push(format!("basal {} U/h", s.join(", ")));
    }
    if let Some([b, l, d]) = c.carb_ratio {
        what.push(format!("carb ratios {b}/{l}/{d} g/U"));
    }
    // In the person's zone, as the advice says it.
    let from = c.instant.parse::<jiff::Timestamp>().map_or_else(
        |_| c.instant.clone(),
        |t| {
            t.to_zoned(p.tz.clone())
                .strftime("%Y-%m-%d %H:%M %Z")
                .to_string()
        },
    );
    println!(
        "Recorded for {}: {}, in force from {from} (the advisor's next update starts from it).",
        a.who.person,
        what.join(", "),
    );
    println!("{NOTICE}");
    Ok(())
}

/// Runs `abba therapy`.
pub fn run(a: Args) -> Result<()> {
    match a.command {
        Command::Set(s) => set(s),
    }
}
