//! A stage's code identity: what the runner's cache keys a stage on instead of its
//! binary's bytes, so that rebuilding unchanged code (a test build, a fresh clone, another
//! machine with the same toolchain) keeps the cache and any change to the code reruns it.
//!
//! The identity of a crate is the blake3 of, in this order:
//! - the format tag [`FORMAT`], the compiler (`rustc -V`), the target triple and the
//!   cargo profile the build script was run for;
//! - the workspace `Cargo.toml` (dependency versions, features, profiles);
//! - every file of every workspace crate the crate depends on, transitively, through its
//!   `[dependencies]` and `[build-dependencies]` (dev-dependencies do not reach a binary),
//!   itself included — as relative path and bytes, sorted by path, skipping `target/` and
//!   hidden entries;
//! - the name, version, source and checksum of every registry crate in that closure, as
//!   `Cargo.lock` resolves it;
//! - any extra files the caller names (a binary's `main`).
//!
//! Used from a build script ([`emit`]), which also tells cargo to rerun it when any of
//! those inputs change, so the identity compiled into the binary is always current.

use std::collections::{BTreeMap, BTreeSet, VecDeque};
use std::fmt;
use std::fs;
use std::path::{Path, PathBuf};

/// Bumped whenever what the identity covers changes.
pub const FORMAT: &str = "reprise-code-id/1";

/// Why an identity could not be computed.
#[derive(Debug)]
pub struct Error(String);

impl fmt::Display for Error {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.write_str(&self.0)
    }
}

impl std::error::Error for Error {}

type Result<T> = std::result::Result<T, Error>;

fn err(path: &Path, what: impl fmt::Display) -> Error {
    Error(format!("{}: {what}", path.display()))
}

/// A computed identity and the files and directories it was computed from.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct CodeId {
    /// Hex blake3.
    pub hex: String,
    /// What a build script must watch: the crate directories, the workspace manifest,
    /// `Cargo.lock` and the extra files.
    pub watched: Vec<PathBuf>,
}

/// The build environment that is part of the identity.
#[derive(Debug, Clone, PartialEq, Eq, Default)]
pub struct Toolchain {
    /// `rustc -V`.
    pub rustc: String,
    /// Target triple.
    pub target: String,
    /// Cargo profile (`release`, `debug`).
    pub profile: String,
}

impl Toolchain {
    /// The toolchain of the running build script (`RUSTC`, `TARGET`, `PROFILE`).
    pub fn from_build_env() -> Self {
        let var = |k: &str| std::env::var(k).unwrap_or_default();
        let rustc = std::process::Command::new(std::env::var("RUSTC").unwrap_or_else(|_| "rustc".into()))
            .arg("-V")
            .output()
            .ok()
            .map(|o| String::from_utf8_lossy(&o.stdout).trim().to_string())
            .unwrap_or_default();
        Self { rustc, target: var("TARGET"), profile: var("PROFILE") }
    }
}

/// The identity of the crates at `crates` (their manifest directories) and everything they
/// depend on, plus `extra` files, built by `toolchain`.
pub fn code_id(crates: &[&Path], extra: &[&Path], toolchain: &Toolchain) -> Result<CodeId> {
    let first = crates.first().ok_or_else(|| Error("no crate given".into()))?;
    let root = workspace_root(first)?;
    let lock = Lock::read(&root.join("Cargo.lock"))?;
    let ws_manifest = root.join("Cargo.toml");
    let ws = read_toml(&ws_manifest)?;
    let ws_deps = ws.get("workspace").and_then(|w| w.get("dependencies")).and_then(toml::Value::as_table);

    // Workspace crates reachable through normal and build dependencies.
    let mut local: BTreeMap<PathBuf, String> = BTreeMap::new(); // dir → package name
    let mut external: BTreeSet<String> = BTreeSet::new(); // lock keys "name version"
    let mut todo: VecDeque<PathBuf> = crates.iter().map(|c| canonical(c)).collect::<Result<_>>()?;
    while let Some(dir) = todo.pop_front() {
        if local.contains_key(&dir) {
            continue;
        }
        let manifest = dir.join("Cargo.toml");
        let m = read_toml(&manifest)?;
        let name = m
            .get("package")
            .and_then(|p| p.get("name"))
            .and_then(toml::Value::as_str)
            .ok_or_else(|| err(&manifest, "no [package] name"))?
            .to_string();
        let mut registry_names = BTreeSet::new();
        for (dep, spec) in dependencies(&m) {
            let (path, package) = match spec.get("workspace").and_then(toml::Value::as_bool) {
                Some(true) => {
                    let w = ws_deps.and_then(|d| d.get(&dep)).ok_or_else(|| {
                        err(&manifest, format!("`{dep}` is `workspace = true` but not in [workspace.dependencies]"))
                    })?;
                    (w.get("path").and_then(toml::Value::as_str).map(|p| root.join(p)), package_of(w, &dep))
                }
                _ => (spec.get("path").and_then(toml::Value::as_str).map(|p| dir.join(p)), package_of(&spec, &dep)),
            };
            match path {
                Some(p) => todo.push_back(canonical(&p)?),
                None => {
                    registry_names.insert(package);
                }
            }
        }
        // The lock resolves this crate's registry dependencies exactly (its entry also
        // lists dev-dependencies, which the names from the manifest filter out).
        for key in lock.deps_of(&name).into_iter().filter(|k| registry_names.contains(Lock::name_of(k))) {
            external.insert(key);
        }
        local.insert(dir, name);
    }
    let external = lock.closure(external);

    let mut h = blake3::Hasher::new();
    let mut field = |tag: &str, bytes: &[u8]| {
        h.update(tag.as_bytes());
        h.update(&(bytes.len() as u64).to_le_bytes());
        h.update(bytes);
    };
    field("format", FORMAT.as_bytes());
    field("rustc", toolchain.rustc.as_bytes());
    field("target", toolchain.target.as_bytes());
    field("profile", toolchain.profile.as_bytes());
    field("workspace", &fs::read(&ws_manifest).map_err(|e| err(&ws_manifest, e))?);
    for dir in local.keys() {
        let mut files = Vec::new();
        walk(dir, &mut files)?;
        files.sort();
        for f in files {
            let rel = f.strip_prefix(&root).unwrap_or(&f).to_string_lossy().replace('\\', "/");
            field(&format!("file {rel}"), &fs::read(&f).map_err(|e| err(&f, e))?);
        }
    }
    for key in &external {
        field("registry", lock.describe(key).as_bytes());
    }
    for f in extra {
        let rel = canonical(f)?;
        let shown = rel.strip_prefix(&root).unwrap_or(&rel).to_string_lossy().replace('\\', "/");
        field(&format!("extra {shown}"), &fs::read(f).map_err(|e| err(f, e))?);
    }
    let mut watched: Vec<PathBuf> = local.into_keys().collect();
    watched.extend([ws_manifest, root.join("Cargo.lock")]);
    watched.extend(extra.iter().map(|p| p.to_path_buf()));
    Ok(CodeId { hex: h.finalize().to_hex().to_string(), watched })
}

/// For a build script: computes the identity of `crates` (+ `extra`) and sets the
/// compile-time environment variable `var` to it (`unknown: <why>` if it cannot be
/// computed, with a cargo warning — the runner then falls back to hashing the binary),
/// and asks cargo to rerun the script when any input changes.
pub fn emit(var: &str, crates: &[&Path], extra: &[&Path]) {
    match code_id(crates, extra, &Toolchain::from_build_env()) {
        Ok(id) => {
            for w in &id.watched {
                println!("cargo:rerun-if-changed={}", w.display());
            }
            println!("cargo:rustc-env={var}={}", id.hex);
        }
        Err(e) => {
            println!(
                "cargo:warning=code identity for {var}: {e}; the runner will key this stage on its binary's bytes"
            );
            println!("cargo:rustc-env={var}=unknown");
        }
    }
    println!("cargo:rerun-if-env-changed=RUSTC");
}

fn canonical(p: &Path) -> Result<PathBuf> {
    fs::canonicalize(p).map_err(|e| err(p, e))
}

fn read_toml(path: &Path) -> Result<toml::Value> {
    let text = fs::read_to_string(path).map_err(|e| err(path, e))?;
    text.parse::<toml::Value>().map_err(|e| err(path, e))
}

/// The nearest ancestor of `dir` (itself included) whose `Cargo.toml` has `[workspace]`.
fn workspace_root(dir: &Path) -> Result<PathBuf> {
    let start = canonical(dir)?;
    for d in start.ancestors() {
        let m = d.join("Cargo.toml");
        if m.is_file() && read_toml(&m)?.get("workspace").is_some() {
            return Ok(d.to_path_buf());
        }
    }
    Err(err(&start, "not inside a cargo workspace"))
}

/// `(name, spec)` of every normal and build dependency, target-specific ones included
/// (a bare version string becomes an empty table).
fn dependencies(m: &toml::Value) -> Vec<(String, toml::Value)> {
    let mut tables: Vec<&toml::Value> = Vec::new();
    for section in ["dependencies", "build-dependencies"] {
        tables.extend(m.get(section));
        if let Some(targets) = m.get("target").and_then(toml::Value::as_table) {
            tables.extend(targets.values().filter_map(|t| t.get(section)));
        }
    }
    tables
        .into_iter()
        .filter_map(toml::Value::as_table)
        .flat_map(|t| t.iter())
        .map(|(k, v)| (k.clone(), if v.is_table() { v.clone() } else { toml::Value::Table(Default::default()) }))
        .collect()
}

fn package_of(spec: &toml::Value, dep: &str) -> String {
    spec.get("package").and_then(toml::Value::as_str).unwrap_or(dep).to_string()
}

/// Every file under `dir`, skipping `target` and hidden entries.
fn walk(dir: &Path, out: &mut Vec<PathBuf>) -> Result<()> {
    let mut entries: Vec<_> =
        fs::read_dir(dir).map_err(|e| err(dir, e))?.collect::<std::io::Result<_>>().map_err(|e| err(dir, e))?;
    entries.sort_by_key(|e| e.file_name());
    for e in entries {
        let name = e.file_name();
        let name = name.to_string_lossy();
        if name.starts_with('.') || name == "target" {
            continue;
        }
        let path = e.path();
        let kind = e.file_type().map_err(|x| err(&path, x))?;
        if kind.is_dir() {
            walk(&path, out)?;
        } else if kind.is_file() {
            out.push(path);
        }
    }
    Ok(())
}

/// `Cargo.lock`, keyed `"name version"`.
struct Lock {
    packages: BTreeMap<String, LockPackage>,
}

struct LockPackage {
    describe: String,
    deps: Vec<String>,
}

impl Lock {
    fn read(path: &Path) -> Result<Self> {
        let v = read_toml(path)?;
        let list = v.get("package").and_then(toml::Value::as_array).ok_or_else(|| err(path, "no [[package]]"))?;
        let s = |p: &toml::Value, k: &str| p.get(k).and_then(toml::Value::as_str).unwrap_or("").to_string();
        let raw: Vec<(String, String, String, Vec<String>)> = list
            .iter()
            .map(|p| {
                let deps = p
                    .get("dependencies")
                    .and_then(toml::Value::as_array)
                    .map(|d| d.iter().filter_map(toml::Value::as_str).map(String::from).collect())
                    .unwrap_or_default();
                (s(p, "name"), s(p, "version"), format!("{} {}", s(p, "source"), s(p, "checksum")), deps)
            })
            .collect();
        // A dependency string is `name` when the lock has one package of that name, else
        // `name version` (optionally followed by ` (source)`).
        let versions: BTreeMap<&str, Vec<&str>> = raw.iter().fold(BTreeMap::new(), |mut m, (n, v, _, _)| {
            m.entry(n.as_str()).or_default().push(v.as_str());
            m
        });
        let resolve = |d: &str| -> String {
            let mut it = d.split(' ');
            let name = it.next().unwrap_or("");
            match it.next() {
                Some(v) => format!("{name} {v}"),
                None => format!("{name} {}", versions.get(name).and_then(|v| v.first()).copied().unwrap_or("")),
            }
        };
        let packages = raw
            .iter()
            .map(|(n, v, src, deps)| {
                let key = format!("{n} {v}");
                let describe = format!("{key} {src}");
                (key, LockPackage { describe, deps: deps.iter().map(|d| resolve(d)).collect() })
            })
            .collect();
        Ok(Self { packages })
    }

    fn name_of(key: &str) -> &str {
        key.split(' ').next().unwrap_or("")
    }

    /// The resolved dependencies of the (unique) package `name`.
    fn deps_of(&self, name: &str) -> Vec<String> {
        self.packages
            .iter()
            .filter(|(k, _)| Self::name_of(k) == name)
            .flat_map(|(_, p)| p.deps.iter().cloned())
            .collect()
    }

    /// `start` and everything it depends on.
    fn closure(&self, start: BTreeSet<String>) -> BTreeSet<String> {
        let mut seen = BTreeSet::new();
        let mut todo: Vec<String> = start.into_iter().collect();
        while let Some(k) = todo.pop() {
            if !seen.insert(k.clone()) {
                continue;
            }
            if let Some(p) = self.packages.get(&k) {
                todo.extend(p.deps.iter().filter(|d| !seen.contains(*d)).cloned());
            }
        }
        seen
    }

    fn describe(&self, key: &str) -> String {
        self.packages.get(key).map_or_else(|| key.to_string(), |p| p.describe.clone())
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A workspace of three crates: `app` depends on `lib` (by path) and on a registry
    /// crate; `other` is not a dependency; `lib` has a dev-dependency on `other`.
    fn workspace() -> tempfile::TempDir {
        let d = tempfile::tempdir().unwrap();
        let w = |rel: &str, text: &str| {
            let p = d.path().join(rel);
            fs::create_dir_all(p.parent().unwrap()).unwrap();
            fs::write(p, text).unwrap();
        };
        w("Cargo.toml", "[workspace]\nmembers = [\"app\", \"lib\", \"other\"]\n[workspace.dependencies]\nlib = { path = \"lib\" }\n");
        w("app/Cargo.toml", "[package]\nname = \"app\"\n[dependencies]\nlib.workspace = true\nitoa = \"1\"\n");
        w("app/src/main.rs", "fn main() {}\n");
        w("lib/Cargo.toml", "[package]\nname = \"lib\"\n[dev-dependencies]\nother = { path = \"../other\" }\n");
        w("lib/src/lib.rs", "pub fn f() {}\n");
        w("lib/target/junk", "build output\n");
        w("other/Cargo.toml", "[package]\nname = \"other\"\n");
        w("other/src/lib.rs", "pub fn g() {}\n");
        w(
            "Cargo.lock",
            "version = 4\n[[package]]\nname = \"app\"\nversion = \"0.1.0\"\ndependencies = [\"itoa\", \"lib\"]\n\
             [[package]]\nname = \"itoa\"\nversion = \"1.0.1\"\nsource = \"registry\"\nchecksum = \"abc\"\n\
             [[package]]\nname = \"lib\"\nversion = \"0.1.0\"\ndependencies = [\"other\"]\n\
             [[package]]\nname = \"other\"\nversion = \"0.1.0\"\n",
        );
        d
    }

    fn id(d: &Path) -> String {
        code_id(&[&d.join("app")], &[], &Toolchain::default()).unwrap().hex
    }

    #[test]
    fn the_identity_follows_the_code_it_links_and_nothing_else() {
        let d = workspace();
        let base = id(d.path());
        assert_eq!(id(d.path()), base, "deterministic");
        // Not linked: a dev-dependency's source, build output, hidden files.
        fs::write(d.path().join("other/src/lib.rs"), "pub fn g() { /* changed */ }\n").unwrap();
        fs::write(d.path().join("lib/target/junk"), "other build output\n").unwrap();
        fs::write(d.path().join("lib/.hidden"), "x").unwrap();
        assert_eq!(id(d.path()), base, "unlinked changes keep the identity");
        // Linked: a dependency's source, a new file in it, the registry crate's version.
        let changed = |rel: &str, text: &str| {
            let before = fs::read_to_string(d.path().join(rel)).unwrap_or_default();
            fs::write(d.path().join(rel), text).unwrap();
            let after = id(d.path());
            fs::write(d.path().join(rel), before).unwrap();
            after
        };
        assert_ne!(changed("lib/src/lib.rs", "pub fn f() { 1; }\n"), base, "dependency source");
        assert_ne!(changed("app/src/main.rs", "fn main() { 2; }\n"), base, "own source");
        let lock = fs::read_to_string(d.path().join("Cargo.lock")).unwrap();
        assert_ne!(changed("Cargo.lock", &lock.replace("1.0.1", "1.0.2")), base, "registry version");
        assert_eq!(id(d.path()), base);
        let other = Toolchain { rustc: "rustc 9.9".into(), ..Toolchain::default() };
        assert_ne!(code_id(&[&d.path().join("app")], &[], &other).unwrap().hex, base, "compiler");
    }

    #[test]
    fn what_to_watch_and_clear_errors() {
        let d = workspace();
        let got = code_id(&[&d.path().join("app")], &[], &Toolchain::default()).unwrap();
        let names: Vec<String> =
            got.watched.iter().map(|p| p.file_name().unwrap().to_string_lossy().into_owned()).collect();
        assert_eq!(names, ["app", "lib", "Cargo.toml", "Cargo.lock"]);
        fs::write(
            d.path().join("app/Cargo.toml"),
            "[package]\nname = \"app\"\n[dependencies]\nnope.workspace = true\n",
        )
        .unwrap();
        let e = code_id(&[&d.path().join("app")], &[], &Toolchain::default()).unwrap_err().to_string();
        assert!(e.contains("app/Cargo.toml") && e.contains("`nope`"), "{e}");
        let outside = tempfile::tempdir().unwrap();
        let e = code_id(&[outside.path()], &[], &Toolchain::default()).unwrap_err().to_string();
        assert!(e.contains("not inside a cargo workspace"), "{e}");
    }
}
