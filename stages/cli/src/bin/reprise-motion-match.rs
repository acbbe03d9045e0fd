//! `reprise-motion-match`: see `reprise_motion_match` for what it does.
use clap::Parser;

fn main() {
    let args = reprise_motion_match::Args::parse();
    reprise_stagekit::main("reprise-motion-match", || {
        if let Some(answers) = reprise_motion_match::run(&args)? {
            for (s, name) in ["motion-matching", "crossfade"].into_iter().enumerate() {
                let mut l: Vec<i64> = answers.iter().filter_map(|(_, a)| a[s].latency).collect();
                l.sort_unstable();
                let median = l.get(l.len() / 2).map_or("-".to_string(), |v| v.to_string());
                eprintln!(
                    "{name:<16} answered {:>4} / {:<4} requests, median latency {median} frames",
                    l.len(),
                    answers.len()
                );
            }
        }
        Ok(())
    });
}
