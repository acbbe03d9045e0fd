//! Tests of the HTML page in headless Chromium (Debian's `chromium`; each test says
//! `SKIPPED` on stderr and passes where it is missing). Checked: no script errors (the
//! page's error hook and Chromium's console log), both players report `data-ready="true"`
//! after drawing their first frame, every section is present, and a screenshot of the
//! player opened mid-transition (`#transition-player=<group>,<frame>`) shows the meshes
//! (enough tinted pixels: the page itself is black, grey and white).
//!
//! `synthetic_page_in_chromium` renders a page built here (a waving sheet, three systems
//! of which one has no answer, a script). `report_page_in_chromium` checks a real report:
//! `REPRISE_REPORT_PAGE=reports/dragon-face/index.html cargo test --release -p
//! reprise-evaluate report_page`.

use std::path::{Path, PathBuf};
use std::process::Command;

use crate::aggregate::{exact, metric};
use crate::charts::LatentPanel;
use crate::html::{self, Page};
use crate::player::{Clip, Group, Player};
use reprise_stagekit::StageResult;

/// Sections every page has (element ids).
pub const SECTIONS: [&str; 12] = [
    "conclusions",
    "metrics",
    "player",
    "transition-player",
    "figures",
    "latency",
    "plausibility",
    "coverage",
    "traces",
    "latents",
    "definitions",
    "provenance",
];

/// What one headless run saw.
pub struct Seen {
    /// The DOM after the scripts ran.
    pub dom: String,
    /// Chromium's log (console messages included).
    pub log: String,
    /// Tinted pixels in the screenshot.
    pub tinted: usize,
    /// The screenshot.
    pub png: PathBuf,
}

fn chromium() -> Option<PathBuf> {
    ["chromium", "chromium-browser"].iter().find_map(|c| {
        let out = Command::new("sh").args(["-c", &format!("command -v {c}")]).output().ok()?;
        out.status.success().then(|| PathBuf::from(String::from_utf8_lossy(&out.stdout).trim()))
    })
}

fn headless(bin: &Path, profile: &Path, extra: &[&str], url: &str) -> std::process::Output {
    let mut c = Command::new(bin);
    c.args([
        "--headless",
        "--no-sandbox",
        "--disable-gpu",
        "--no-first-run",
        "--disable-background-networking",
        "--disable-component-update",
        "--disable-sync",
        "--enable-logging=stderr",
        "--v=0",
        "--virtual-time-budget=10000",
    ])
    .arg(format!("--user-data-dir={}", profile.display()))
    .args(extra)
    .arg(url);
    c.output().expect("chromium runs")
}

/// Loads `page` in headless Chromium: the DOM, then a screenshot with `hash`.
pub fn load(page: &Path, hash: &str, shot: &Path) -> Option<Seen> {
    let Some(bin) = chromium() else {
        eprintln!("SKIPPED: no chromium on PATH (apt-get install chromium)");
        return None;
    };
    let page = std::fs::canonicalize(page).expect("page exists");
    // One profile per run: Chromium refuses a profile another instance holds (tests run
    // in parallel).
    static RUNS: std::sync::atomic::AtomicUsize = std::sync::atomic::AtomicUsize::new(0);
    let run = RUNS.fetch_add(1, std::sync::atomic::Ordering::Relaxed);
    let profile = std::env::temp_dir().join(format!("reprise-chromium-{}-{run}", std::process::id()));
    let url = format!("file://{}", page.display());
    let dom = headless(&bin, &profile, &["--dump-dom"], &url);
    let window = "--window-size=1280,1000".to_string();
    let screenshot = format!("--screenshot={}", shot.display());
    let shot_run = headless(&bin, &profile, &[&window, &screenshot], &format!("{url}{hash}"));
    let _ = std::fs::remove_dir_all(&profile);
    let log = format!("{}{}", String::from_utf8_lossy(&dom.stderr), String::from_utf8_lossy(&shot_run.stderr));
    Some(Seen { dom: String::from_utf8_lossy(&dom.stdout).into_owned(), log, tinted: tinted(shot), png: shot.into() })
}

/// Pixels whose channels differ by more than 40 (the meshes are tinted; text, rules and the
/// page background are grey).
fn tinted(png_path: &Path) -> usize {
    let Ok(f) = std::fs::File::open(png_path) else { return 0 };
    let mut reader = png::Decoder::new(std::io::BufReader::new(f)).read_info().expect("a PNG");
    let mut buf = vec![0; reader.output_buffer_size()];
    let info = reader.next_frame(&mut buf).expect("PNG frame");
    let ch = info.color_type.samples();
    buf[..info.buffer_size()]
        .chunks_exact(ch)
        .filter(|p| {
            let (lo, hi) = (p[..3].iter().min().unwrap(), p[..3].iter().max().unwrap());
            hi - lo > 40
        })
        .count()
}

/// The checks every page passes.
pub fn assert_page(seen: &Seen, min_tinted: usize) {
    let errors: Vec<&str> =
        seen.log.lines().filter(|l| l.contains("CONSOLE") && (l.contains("Uncaught") || l.contains("Error"))).collect();
    assert!(errors.is_empty(), "console errors: {errors:#?}");
    assert!(!seen.dom.contains("data-js-errors"), "the page's error hook fired: {}", error_of(&seen.dom));
    for id in SECTIONS {
        assert!(seen.dom.contains(&format!("id=\"{id}\"")), "section #{id} missing");
    }
    for p in ["transition-player", "script-player"] {
        let at = seen.dom.find(&format!("id=\"{p}\"")).unwrap_or_else(|| panic!("no #{p}"));
        let tag = &seen.dom[seen.dom[..at].rfind('<').unwrap()..at + seen.dom[at..].find('>').unwrap()];
        assert!(tag.contains("data-ready=\"true\""), "#{p} not ready: {tag}");
        assert!(tag.contains("data-first-frame-ms="), "{tag}");
    }
    assert!(seen.tinted >= min_tinted, "screenshot {} looks blank: {} tinted pixels", seen.png.display(), seen.tinted);
}

fn error_of(dom: &str) -> &str {
    dom.split("data-js-error=\"").nth(1).and_then(|s| s.split('"').next()).unwrap_or("")
}

/// A 12 × 12 sheet (x, y in [-1, 1]) waving with phase `t`: vertices and triangles.
fn sheet(t: f64) -> Vec<f64> {
    let n = 12;
    (0..n * n)
        .flat_map(|i| {
            let (x, y) = (2.0 * (i % n) as f64 / (n - 1) as f64 - 1.0, 2.0 * (i / n) as f64 / (n - 1) as f64 - 1.0);
            [x, y + 0.1 * (3.0 * x + t).sin(), 0.3 * (2.0 * y + t).cos()]
        })
        .collect()
}

fn sheet_triangles() -> Vec<[u32; 3]> {
    let n = 12u32;
    (0..n - 1)
        .flat_map(|y| {
            (0..n - 1).flat_map(move |x| {
                [[y * n + x, y * n + x + 1, (y + 1) * n + x], [y * n + x + 1, (y + 1) * n + x + 1, (y + 1) * n + x]]
            })
        })
        .collect()
}

fn clip(system: &str, offset: usize, frames: usize, asked: i64, latency: Option<i64>) -> Clip {
    Clip {
        system: system.into(),
        offset,
        frames,
        asked,
        latency,
        note: if frames == 0 { "never reached `b`".into() } else { String::new() },
        model: (0..frames).map(|t| u16::from(t as i64 >= asked + latency.unwrap_or(0))).collect(),
        phase: (0..frames).map(|t| if (t as i64) <= asked { 0 } else { 1 }).collect(),
        bridges: if system == "reprise" {
            vec![(asked as usize + 3, asked as usize + 6, "bridge a → b (inferred)".into())]
        } else {
            vec![]
        },
        command: vec![0; frames],
        latent: vec![],
        nearest: (0..frames).map(|t| (t % 60, 0.01)).collect(),
    }
}

/// A page over the waving sheet: two systems with 40 frames each, one without an answer,
/// and a script of 48 frames.
fn synthetic(dir: &Path) -> PathBuf {
    let frames = 40 + 40 + 48;
    let meshes: Vec<f64> = (0..frames).flat_map(|t| sheet(t as f64 * 0.2)).collect();
    let dim = 3 * 144;
    let source = |idx: &[usize]| -> StageResult<Vec<f64>> {
        Ok(idx.iter().flat_map(|&t| meshes[t * dim..(t + 1) * dim].to_vec()).collect())
    };
    let encoded = crate::encode::encode(frames, dim, &source, 1e-3).unwrap();
    let mut script = clip("demo", 80, 48, 0, None);
    script.phase = vec![4; 48];
    script.latent = (0..48).map(|t| vec![t as f64 / 48.0, 0.5]).collect();
    let player = Player {
        rule: "test".into(),
        groups: vec![Group {
            title: "a → b · request 1".into(),
            pair: ("a".into(), "b".into()),
            clips: vec![
                clip("reprise", 0, 40, 10, Some(8)),
                clip("Motion Graphs", 40, 40, 0, Some(20)),
                clip("Crossfade", 0, 0, 0, None),
            ],
        }],
        scripts: vec![Group { title: "script demo".into(), pair: (String::new(), String::new()), clips: vec![script] }],
        labels: vec!["a".into(), "b".into()],
        training: (0..60).map(|r| ("clip0".to_string(), r as i64, "a".to_string())).collect(),
        fps: 24.0,
        bounds: [-1.0, -1.2, 1.0, 1.2],
        triangles: sheet_triangles().into_iter().flatten().collect(),
        bones: vec![],
        mesh_step: 0.05,
        encoded,
    };
    let labels = vec!["a".to_string(), "b".to_string()];
    let systems =
        vec![("reprise".to_string(), "reprise".to_string()), ("motion-graphs".into(), "Motion Graphs".into())];
    let rows = vec![
        metric("reprise", "latency_s", "all", "all", &[0.3, 0.4, 0.5], "s", 1),
        metric("motion-graphs", "latency_s", "all", "all", &[0.9, 1.0, 1.1], "s", 1),
        exact("reprise", "coverage", "a", "b", 1.0, 3, "share"),
        exact("motion-graphs", "coverage", "a", "b", 0.5, 3, "share"),
    ];
    let tris = sheet_triangles();
    let cam = sheet(0.0);
    let page = Page {
        name: "synthetic",
        markdown: "## Definitions\n\n- `latency_s`: **seconds**.",
        latents: vec![LatentPanel { label: "a".into(), segments: vec![vec![[0.0, 0.0], [1.0, 1.0]]] }],
        latent_bridges: vec![(0, [0.0, 0.0], 0, [1.0, 1.0])],
        bridges: vec![("a → b".into(), sheet(0.0), sheet(1.0))],
        filmstrip: None,
        shape: crate::render::Shape { triangles: tris, bones: vec![] },
        camera_mesh: &cam,
        speed: vec![("reprise".into(), vec![-1, 0, 1], vec![0.1, 0.2, 0.1])],
        latencies: vec![("reprise".into(), vec![0.3, 0.4, 0.5], 0), ("Motion Graphs".into(), vec![1.0], 2)],
        traces: vec![("a".into(), vec![(1, 10.0), (2, 5.0), (3, 4.5)])],
        fits: vec![crate::html::FitRow {
            label: "a".into(),
            frames: 3,
            d: 2,
            path: "coarse".into(),
            optimizer: "lbfgs".into(),
            iterations: "3".into(),
            evaluations: 4,
            seconds: 0.5,
            objective: 4.5,
            likelihood: 3.0,
            dynamics: 1.0,
            connectivity: 0.4,
            signal: 0.1,
            connectivity_exact: Some(0.41),
            inducing: 0,
            converged: false,
            stop_reason: "max-iterations".into(),
            rel_decrease: 1e-3,
            rel_gradient: 1e-2,
        }],
        labels: &labels,
        player: Some(player),
        missing: vec!["Crossfade answered none of the 1 requests a → b.".into()],
        provenance: vec![("stage".into(), "test".into())],
    };
    let path = dir.join("index.html");
    let html = crate::report::tests::with_ctx(&systems, &rows, &[], |ctx| html::page(&page, &rows, ctx));
    std::fs::write(&path, html).unwrap();
    path
}

/// The fit table (no browser needed): a capped fit is said NOT converged, with why, and
/// the count of converged labels heads it.
#[test]
fn fit_table_says_which_labels_converged() {
    let dir = std::env::temp_dir().join(format!("reprise-fits-{}", std::process::id()));
    let _ = std::fs::remove_dir_all(&dir);
    std::fs::create_dir_all(&dir).unwrap();
    let html = std::fs::read_to_string(synthetic(&dir)).unwrap();
    assert!(html.contains("0 of 1 labels converged"), "the count is said");
    assert!(html.contains("NOT converged: max-iterations"), "the capped fit is said not converged");
    assert!(html.contains("<table class='fits'>") && html.contains("exact conn."));
    let _ = std::fs::remove_dir_all(&dir);
}

/// The synthetic page: no errors, both players ready, every section, meshes on screen.
#[test]
fn synthetic_page_in_chromium() {
    let dir = std::env::temp_dir().join(format!("reprise-page-{}", std::process::id()));
    let _ = std::fs::remove_dir_all(&dir);
    std::fs::create_dir_all(&dir).unwrap();
    let page = synthetic(&dir);
    let Some(seen) = load(&page, "#transition-player=0,5", &dir.join("shot.png")) else { return };
    assert_page(&seen, 2000);
    assert!(seen.dom.contains("never reached"), "the missing answer is said");
    assert!(seen.dom.contains("What is missing"));
    let _ = std::fs::remove_dir_all(&dir);
}

/// A real report (`REPRISE_REPORT_PAGE`), screenshot kept beside it as `player.png`.
#[test]
fn report_page_in_chromium() {
    let Ok(page) = std::env::var("REPRISE_REPORT_PAGE") else {
        eprintln!("SKIPPED: set REPRISE_REPORT_PAGE to a report's index.html");
        return;
    };
    // Relative to the workspace root (tests run in the crate's directory).
    let page = Path::new(env!("CARGO_MANIFEST_DIR")).join("../..").join(page);
    let shot = page.with_file_name("player.png");
    let Some(seen) = load(&page, "#transition-player=0,12", &shot) else { return };
    assert_page(&seen, 5000);
}
