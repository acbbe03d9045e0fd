//! The docs' links hold: every relative link in `README.md` and `docs/**/*.md` names a
//! file that exists and, when it names an anchor (`file.md#heading`), a heading of that
//! file whose GitHub anchor is the anchor. Links to the web (`http:`, `https:`, `mailto:`)
//! and anything inside code (fenced blocks, inline code spans) are not checked. The README
//! also stays short: the reference lives in `docs/`.
//!
//! Std only, so it runs wherever the workspace builds.

use std::collections::{BTreeMap, HashMap, HashSet};
use std::fs;
use std::path::{Component, Path, PathBuf};

/// The README is for users: what reprise is, the two commands, the report, a new
/// character, and where to read more (issue #25).
const README_MAX_LINES: usize = 250;

fn repo_root() -> PathBuf {
    normalize(&Path::new(env!("CARGO_MANIFEST_DIR")).join("../.."))
}

/// `a/b/../c` → `a/c`, without touching the file system (targets may not exist).
fn normalize(path: &Path) -> PathBuf {
    let mut out = PathBuf::new();
    for part in path.components() {
        match part {
            Component::CurDir => {}
            Component::ParentDir => {
                if !out.pop() {
                    out.push("..");
                }
            }
            other => out.push(other.as_os_str()),
        }
    }
    out
}

/// `README.md`, then every `.md` file under `docs/`, in name order.
fn markdown_files(root: &Path) -> Vec<PathBuf> {
    fn walk(dir: &Path, out: &mut Vec<PathBuf>) {
        let Ok(entries) = fs::read_dir(dir) else { return };
        let mut paths: Vec<PathBuf> = entries.filter_map(|e| e.ok().map(|e| e.path())).collect();
        paths.sort();
        for path in paths {
            if path.is_dir() {
                walk(&path, out);
            } else if path.extension().is_some_and(|e| e == "md") {
                out.push(path);
            }
        }
    }
    let mut files = vec![root.join("README.md")];
    walk(&root.join("docs"), &mut files);
    files
}

/// GitHub's anchor for a heading: lowercase; each space becomes `-`; every other
/// character but letters, digits, `-` and `_` is dropped.
fn slug(heading: &str) -> String {
    heading
        .trim()
        .to_lowercase()
        .chars()
        .filter_map(|c| match c {
            ' ' => Some('-'),
            c if c.is_alphanumeric() || c == '-' || c == '_' => Some(c),
            _ => None,
        })
        .collect()
}

/// Tracks fenced code blocks (```` ``` ```` or `~~~`, closed by a fence of the same
/// character at least as long).
#[derive(Default)]
struct Fences {
    open: Option<(char, usize)>,
}

impl Fences {
    /// Whether `line` is code (inside a block, or one of its fences).
    fn is_code(&mut self, line: &str) -> bool {
        let indent = line.len() - line.trim_start_matches(' ').len();
        let rest = line.trim_start_matches(' ');
        let fence = rest.chars().next().filter(|&c| indent <= 3 && (c == '`' || c == '~')).and_then(|c| {
            let n = rest.chars().take_while(|&x| x == c).count();
            (n >= 3).then_some((c, n, rest[n..].trim()))
        });
        match (self.open, fence) {
            (None, Some((c, n, _))) => {
                self.open = Some((c, n));
                true
            }
            (Some((c, n)), Some((c2, n2, info))) if c2 == c && n2 >= n && info.is_empty() => {
                self.open = None;
                true
            }
            (Some(_), _) => true,
            (None, None) => false,
        }
    }
}

/// The ATX heading a line holds (`## Text ##` → `Text`), if any.
fn heading(line: &str) -> Option<&str> {
    let rest = line.trim_start_matches(' ');
    if line.len() - rest.len() > 3 {
        return None;
    }
    let level = rest.chars().take_while(|&c| c == '#').count();
    if !(1..=6).contains(&level) {
        return None;
    }
    let text = &rest[level..];
    if !(text.is_empty() || text.starts_with(' ') || text.starts_with('\t')) {
        return None;
    }
    Some(text.trim().trim_end_matches('#').trim_end())
}

/// Every anchor of a Markdown file's headings, with GitHub's `-1`, `-2`, … for repeats.
fn anchors(text: &str) -> HashSet<String> {
    let mut fences = Fences::default();
    let mut seen: HashMap<String, usize> = HashMap::new();
    let mut out = HashSet::new();
    for line in text.lines() {
        if fences.is_code(line) {
            continue;
        }
        if let Some(h) = heading(line) {
            let base = slug(h);
            let n = seen.entry(base.clone()).or_insert(0);
            out.insert(if *n == 0 { base.clone() } else { format!("{base}-{n}") });
            *n += 1;
        }
    }
    out
}

/// `line` with its inline code spans blanked (a run of n backticks up to the next run of
/// exactly n), so that code such as `` `a[i](x)` `` is not read as a link.
fn without_code_spans(line: &str) -> String {
    let chars: Vec<char> = line.chars().collect();
    let run = |i: usize| chars[i..].iter().take_while(|&&c| c == '`').count();
    let mut out = String::with_capacity(line.len());
    let mut i = 0;
    while i < chars.len() {
        if chars[i] != '`' {
            out.push(chars[i]);
            i += 1;
            continue;
        }
        let n = run(i);
        let mut j = i + n;
        let mut close = None;
        while j < chars.len() {
            if chars[j] == '`' {
                let m = run(j);
                if m == n {
                    close = Some(j + m);
                    break;
                }
                j += m;
            } else {
                j += 1;
            }
        }
        if let Some(end) = close {
            out.extend(std::iter::repeat_n(' ', end - i));
            i = end;
        } else {
            out.extend(std::iter::repeat_n('`', n));
            i += n;
        }
    }
    out
}

/// The targets of the links on one line of prose: `[text](target "title")`,
/// `![alt](target)` and reference definitions `[label]: target`.
fn link_targets(line: &str) -> Vec<String> {
    let line = without_code_spans(line);
    let mut targets = Vec::new();
    let trimmed = line.trim_start();
    if trimmed.starts_with('[') {
        if let Some(end) = trimmed.find("]:") {
            let target = trimmed[end + 2..].split_whitespace().next().unwrap_or("");
            if !target.is_empty() && !trimmed[1..end].contains('[') {
                targets.push(target.trim_matches(['<', '>']).to_string());
            }
        }
    }
    let mut rest = line.as_str();
    while let Some(at) = rest.find("](") {
        let after = &rest[at + 2..];
        let mut depth = 0usize;
        let mut end = after.len();
        for (k, c) in after.char_indices() {
            match c {
                '(' => depth += 1,
                ')' if depth == 0 => {
                    end = k;
                    break;
                }
                ')' => depth -= 1,
                _ => {}
            }
        }
        let inner = after[..end].trim();
        let target = if let Some(stripped) = inner.strip_prefix('<') {
            stripped.split('>').next().unwrap_or("")
        } else {
            inner.split_whitespace().next().unwrap_or("")
        };
        targets.push(target.to_string());
        rest = &after[end.min(after.len())..];
    }
    targets
}

fn is_external(target: &str) -> bool {
    let lower = target.to_ascii_lowercase();
    ["http://", "https://", "mailto:"].iter().any(|p| lower.starts_with(p))
}

/// Why `target`, linked from `file`, does not resolve; `None` when it does.
fn broken(file: &Path, target: &str, anchors_of: &mut BTreeMap<PathBuf, Option<HashSet<String>>>) -> Option<String> {
    if target.is_empty() {
        return Some("empty link".into());
    }
    let (path, anchor) = match target.split_once('#') {
        Some((p, a)) => (p, Some(a)),
        None => (target, None),
    };
    let resolved = if path.is_empty() {
        file.to_path_buf()
    } else {
        normalize(&file.parent().unwrap_or(Path::new("")).join(path))
    };
    if !resolved.exists() {
        return Some("no such file".into());
    }
    let anchor = anchor?;
    if resolved.is_dir() || resolved.extension().is_none_or(|e| e != "md") {
        return Some("an anchor on a file that is not Markdown".into());
    }
    let known =
        anchors_of.entry(resolved.clone()).or_insert_with(|| fs::read_to_string(&resolved).ok().map(|t| anchors(&t)));
    match known {
        Some(set) if set.contains(anchor) => None,
        Some(_) => Some("no heading with that anchor".into()),
        None => Some("unreadable file".into()),
    }
}

#[test]
fn every_relative_link_in_the_docs_resolves() {
    let root = repo_root();
    let files = markdown_files(&root);
    assert!(files.len() > 1, "no Markdown under {}", root.join("docs").display());
    let mut anchors_of = BTreeMap::new();
    let mut failures = Vec::new();
    let mut checked = 0usize;
    for file in &files {
        let text = fs::read_to_string(file).unwrap_or_else(|e| panic!("{}: {e}", file.display()));
        let shown = file.strip_prefix(&root).unwrap_or(file).display().to_string();
        let mut fences = Fences::default();
        for (n, line) in text.lines().enumerate() {
            if fences.is_code(line) {
                continue;
            }
            for target in link_targets(line) {
                if is_external(&target) {
                    continue;
                }
                checked += 1;
                if let Some(why) = broken(file, &target, &mut anchors_of) {
                    failures.push(format!("{shown}:{} -> {target} ({why})", n + 1));
                }
            }
        }
    }
    assert!(
        failures.is_empty(),
        "{} broken link(s) of {checked} checked in README.md and docs/:\n{}",
        failures.len(),
        failures.join("\n")
    );
}

#[test]
fn the_readme_is_short() {
    let path = repo_root().join("README.md");
    let lines = fs::read_to_string(&path).unwrap_or_else(|e| panic!("{}: {e}", path.display())).lines().count();
    assert!(
        lines <= README_MAX_LINES,
        "README.md has {lines} lines, more than {README_MAX_LINES}: move reference to docs/ (docs/README.md is the index)"
    );
}

#[test]
fn slugs_are_github_anchors() {
    for (heading, anchor) in [
        ("The GPLVM fit", "the-gplvm-fit"),
        ("Running on a Slurm cluster", "running-on-a-slurm-cluster"),
        ("`bridges` (bridges)", "bridges-bridges"),
        ("`pipeline.toml`", "pipelinetoml"),
        ("A stage's identity is its code, not its bytes", "a-stages-identity-is-its-code-not-its-bytes"),
        ("`mg_nodes`, `mg_edges` (motion-graph)", "mg_nodes-mg_edges-motion-graph"),
        ("Issue #11: every label converges", "issue-11-every-label-converges"),
        (
            "Partitioned stages: one label (or pair of labels) at a time",
            "partitioned-stages-one-label-or-pair-of-labels-at-a-time",
        ),
        ("Speed — and time", "speed--and-time"),
    ] {
        assert_eq!(slug(heading), anchor, "{heading}");
    }
}

#[test]
fn links_are_found_outside_code_only() {
    assert_eq!(link_targets("see [a](x.md#b) and ![c](img.png \"title\")"), ["x.md#b", "img.png"]);
    assert_eq!(link_targets("`[not](a link)` but [this](one.md)"), ["one.md"]);
    assert_eq!(link_targets("`` `[x](y)` `` [z](<with space.md>)"), ["with space.md"]);
    assert_eq!(link_targets("[ref]: docs/x.md"), ["docs/x.md"]);
    assert!(link_targets("math $[0,1)$ and $[v]_\\times$, arrays [1, 2] (no link)").is_empty());
    let mut fences = Fences::default();
    let code: Vec<bool> =
        ["text", "```sh", "# not a heading", "```", "## Heading"].iter().map(|l| fences.is_code(l)).collect();
    assert_eq!(code, [false, true, true, true, false]);
    let found = anchors("# Top\n```\n# comment\n```\n## Top\n## `a_b` (c)\n");
    let expected: HashSet<String> = ["top", "top-1", "a_b-c"].iter().map(|s| (*s).to_string()).collect();
    assert_eq!(found, expected);
}
