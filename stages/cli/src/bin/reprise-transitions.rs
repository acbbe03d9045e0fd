//! `reprise-transitions`: see `reprise_transitions` for what it does.
use clap::Parser;

fn main() {
    let args = reprise_transitions::Args::parse();
    reprise_stagekit::main("reprise-transitions", || {
        if let Some(reqs) = reprise_transitions::run(&args)? {
            for (s, name) in ["reprise", "baseline"].into_iter().enumerate() {
                let mut l: Vec<i64> = reqs.iter().filter_map(|(_, a)| a[s].latency).collect();
                l.sort_unstable();
                let median = l.get(l.len() / 2).map_or("-".to_string(), |v| v.to_string());
                eprintln!(
                    "{name:<10} answered {:>4} / {:<4} requests, median latency {median} frames",
                    l.len(),
                    reqs.len()
                );
            }
        }
        Ok(())
    });
}
