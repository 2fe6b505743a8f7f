//! Tidy tests (in the style of rust-analyzer's): `docs/ARCHITECTURE.md` checked against the
//! code, run by `cargo test -p xtask` (and so by CI's test command, README.md).
//!
//! * the workspace dependency graph of every `Cargo.toml` against the document's
//!   "Allowed dependencies" section;
//! * the architecture invariants that a text search can check: builders never see rays,
//!   metrics never mutate trees, traversal never knows the builder, one camera, nothing
//!   re-implements traversal;
//! * the builder registry: unique names, each builder reporting its registered name;
//! * the code map names every crate and every top-level module;
//! * the xtask's commands: one module per command, named after it, none using another, and
//!   the shared modules using none;
//! * no absolute machine paths in tracked files;
//! * every crate README with a Rust example is compiled as a doctest.

use std::collections::{BTreeMap, BTreeSet};
use std::fs;
use std::path::{Path, PathBuf};

fn root() -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR"))
        .parent()
        .expect("xtask has a parent directory")
        .to_path_buf()
}

fn read(path: &Path) -> String {
    fs::read_to_string(path).unwrap_or_else(|e| panic!("cannot read {}: {e}", path.display()))
}

fn rel(path: &Path) -> String {
    path.strip_prefix(root())
        .unwrap_or(path)
        .display()
        .to_string()
}

fn architecture() -> String {
    read(&root().join("docs/ARCHITECTURE.md"))
}

/// The directories under `crates/`, sorted.
fn crate_dirs() -> Vec<String> {
    let mut dirs: Vec<String> = fs::read_dir(root().join("crates"))
        .expect("crates/ is readable")
        .map(|e| e.expect("crates/ entry"))
        .filter(|e| e.path().join("Cargo.toml").is_file())
        .map(|e| e.file_name().to_string_lossy().into_owned())
        .collect();
    dirs.sort();
    dirs
}

/// Every workspace member's manifest: `crates/*/Cargo.toml`, `xtask/Cargo.toml`,
/// `benches/Cargo.toml`.
fn manifests() -> Vec<PathBuf> {
    let mut v: Vec<PathBuf> = crate_dirs()
        .iter()
        .map(|d| root().join("crates").join(d).join("Cargo.toml"))
        .collect();
    v.push(root().join("xtask/Cargo.toml"));
    v.push(root().join("benches/Cargo.toml"));
    v
}

/// What a manifest declares, from a small line-based reading of its sections.
#[derive(Debug, Default)]
struct Manifest {
    name: String,
    /// `[dependencies]`, `[build-dependencies]` and `[target.'…'.dependencies]`.
    deps: BTreeSet<String>,
    /// `[dev-dependencies]` and `[target.'…'.dev-dependencies]`.
    dev_deps: BTreeSet<String>,
}

fn parse_manifest(path: &Path) -> Manifest {
    #[derive(PartialEq)]
    enum Section {
        Package,
        Deps,
        DevDeps,
        Other,
    }
    let mut m = Manifest::default();
    let mut section = Section::Other;
    for line in read(path).lines() {
        let line = line.trim();
        if line.is_empty() || line.starts_with('#') {
            continue;
        }
        if line.starts_with('[') {
            let header = line.trim_start_matches('[').trim_end_matches(']').trim();
            section = if header == "package" {
                Section::Package
            } else if header == "dependencies"
                || header == "build-dependencies"
                || (header.starts_with("target.") && header.ends_with(".dependencies"))
                || (header.starts_with("target.") && header.ends_with(".build-dependencies"))
            {
                Section::Deps
            } else if header == "dev-dependencies"
                || (header.starts_with("target.") && header.ends_with(".dev-dependencies"))
            {
                Section::DevDeps
            } else {
                Section::Other
            };
            continue;
        }
        let Some((key, value)) = line.split_once('=') else {
            continue;
        };
        let key = key.trim();
        match section {
            Section::Package if key == "name" => {
                m.name = value.trim().trim_matches('"').to_string();
            }
            Section::Deps | Section::DevDeps => {
                // `name.workspace = true`, `name = "1"`, `name = { … }`.
                let name = key
                    .split('.')
                    .next()
                    .unwrap_or(key)
                    .trim()
                    .trim_matches('"');
                if section == Section::Deps {
                    m.deps.insert(name.to_string());
                } else {
                    m.dev_deps.insert(name.to_string());
                }
            }
            _ => {}
        }
    }
    assert!(
        !m.name.is_empty(),
        "{}: no `[package] name` found",
        rel(path)
    );
    m
}

fn is_workspace_crate(name: &str) -> bool {
    name.starts_with("sahara-") || name == "sahara" || name == "xtask"
}

/// The "Allowed dependencies" section: crate → (allowed in `[dependencies]`, extra allowed in
/// `[dev-dependencies]`).
type Allowed = BTreeMap<String, (BTreeSet<String>, BTreeSet<String>)>;

fn allowed_dependencies(doc: &str) -> Allowed {
    let section = doc_section(doc, "## Allowed dependencies")
        .expect("docs/ARCHITECTURE.md: no `## Allowed dependencies` section");
    let mut allowed = Allowed::new();
    for line in section.lines() {
        let Some(item) = line.strip_prefix("* ") else {
            continue;
        };
        let Some((lhs, rhs)) = item.split_once('→') else {
            continue;
        };
        let names = backticked(lhs);
        assert_eq!(
            names.len(),
            1,
            "docs/ARCHITECTURE.md, Allowed dependencies: `{line}` must name one crate before →"
        );
        let entry = allowed.entry(names[0].clone()).or_default();
        let targets: BTreeSet<String> = backticked(rhs).into_iter().collect();
        assert!(
            !targets.is_empty() || rhs.trim() == "(none)",
            "docs/ARCHITECTURE.md, Allowed dependencies: `{line}`: list crates in backticks \
             after →, or write `(none)`"
        );
        if lhs.contains("(tests)") {
            entry.1.extend(targets);
        } else {
            entry.0.extend(targets);
        }
    }
    allowed
}

/// The text from a heading line to the next heading of the same or a higher level.
fn doc_section<'a>(doc: &'a str, heading: &str) -> Option<&'a str> {
    let level = heading.chars().take_while(|&c| c == '#').count();
    let start = doc.find(&format!("\n{heading}\n"))? + 1;
    let body = &doc[start + heading.len()..];
    let mut end = body.len();
    let mut offset = 0;
    for line in body.split_inclusive('\n') {
        let hashes = line.chars().take_while(|&c| c == '#').count();
        if hashes >= 1 && hashes <= level && line[hashes..].starts_with(' ') {
            end = offset;
            break;
        }
        offset += line.len();
    }
    Some(&doc[start..start + heading.len() + end])
}

/// The contents of the `` `…` `` spans of a text.
fn backticked(text: &str) -> Vec<String> {
    text.split('`')
        .skip(1)
        .step_by(2)
        .map(str::to_string)
        .collect()
}

#[test]
fn dependency_graph_matches_architecture() {
    let doc = architecture();
    let allowed = allowed_dependencies(&doc);
    let manifests: Vec<(PathBuf, Manifest)> = manifests()
        .into_iter()
        .map(|p| (p.clone(), parse_manifest(&p)))
        .collect();
    let names: BTreeSet<&str> = manifests.iter().map(|(_, m)| m.name.as_str()).collect();
    let mut errors = Vec::new();

    for (krate, (deps, dev)) in &allowed {
        for n in std::iter::once(krate).chain(deps).chain(dev) {
            if !names.contains(n.as_str()) {
                errors.push(format!(
                    "docs/ARCHITECTURE.md, Allowed dependencies: `{n}` is not a workspace crate \
                     (the crates are {names:?}); fix or remove the line"
                ));
            }
        }
    }
    for (path, m) in &manifests {
        let Some((deps, dev)) = allowed.get(&m.name) else {
            errors.push(format!(
                "docs/ARCHITECTURE.md, Allowed dependencies: no line for `{}` ({}); add \
                 \"* `{}` → …\"",
                m.name,
                rel(path),
                m.name
            ));
            continue;
        };
        for d in m.deps.iter().filter(|d| is_workspace_crate(d)) {
            if !deps.contains(d) {
                errors.push(format!(
                    "{}: [dependencies] has `{d}`, which docs/ARCHITECTURE.md (Allowed \
                     dependencies) does not allow for `{}`; remove the dependency, or add it to \
                     the line \"* `{}` → …\" if the new edge is intended",
                    rel(path),
                    m.name,
                    m.name
                ));
            }
        }
        for d in m.dev_deps.iter().filter(|d| is_workspace_crate(d)) {
            if !deps.contains(d) && !dev.contains(d) {
                errors.push(format!(
                    "{}: [dev-dependencies] has `{d}`, which docs/ARCHITECTURE.md (Allowed \
                     dependencies) does not allow for `{}`; remove the dependency, or add it to \
                     the line \"* `{}` (tests) → …\" if the new edge is intended",
                    rel(path),
                    m.name,
                    m.name
                ));
            }
        }
    }
    assert!(errors.is_empty(), "\n{}\n", errors.join("\n"));
}

/// The `.rs` files under a directory, recursively, sorted.
fn rust_files(dir: &Path) -> Vec<PathBuf> {
    let mut out = Vec::new();
    let mut stack = vec![dir.to_path_buf()];
    while let Some(d) = stack.pop() {
        for e in fs::read_dir(&d).unwrap_or_else(|e| panic!("cannot read {}: {e}", d.display())) {
            let p = e.expect("directory entry").path();
            if p.is_dir() {
                stack.push(p);
            } else if p.extension().is_some_and(|x| x == "rs") {
                out.push(p);
            }
        }
    }
    out.sort();
    out
}

/// The lines of a source file with their 1-based numbers, without `//` comments (whole-line
/// comments are dropped, trailing ones cut off).
fn code_lines(src: &str) -> Vec<(usize, String)> {
    src.lines()
        .enumerate()
        .filter(|(_, l)| !l.trim_start().starts_with("//"))
        .map(|(i, l)| {
            let code = match l.find("//") {
                // `//` inside a string literal (e.g. a URL) is not a comment: cut only when the
                // quotes before it are balanced.
                Some(at) if l[..at].matches('"').count() % 2 == 0 => &l[..at],
                _ => l,
            };
            (i + 1, code.to_string())
        })
        .collect()
}

/// Blanks out `#[cfg(test)]` items (the attribute's item up to its matching closing brace),
/// keeping line numbers.
fn without_test_code(src: &str) -> String {
    let lines: Vec<&str> = src.lines().collect();
    let mut keep = vec![true; lines.len()];
    let mut i = 0;
    while i < lines.len() {
        if lines[i].trim() == "#[cfg(test)]" {
            let mut depth = 0i64;
            let mut opened = false;
            let mut j = i;
            while j < lines.len() {
                keep[j] = false;
                for c in lines[j].chars() {
                    match c {
                        '{' => {
                            depth += 1;
                            opened = true;
                        }
                        '}' => depth -= 1,
                        _ => {}
                    }
                }
                let ends_item = !lines[j].trim_start().starts_with("#[")
                    && lines[j].trim_end().ends_with(';')
                    && !opened;
                if (opened && depth <= 0) || ends_item {
                    break;
                }
                j += 1;
            }
            i = j + 1;
        } else {
            i += 1;
        }
    }
    lines
        .iter()
        .zip(keep)
        .map(|(l, k)| if k { *l } else { "" })
        .collect::<Vec<_>>()
        .join("\n")
}

fn is_ident_char(c: char) -> bool {
    c.is_alphanumeric() || c == '_'
}

/// Whether `word` occurs in `line` as a whole identifier.
fn has_word(line: &str, word: &str) -> bool {
    line.match_indices(word).any(|(at, _)| {
        let before = line[..at].chars().next_back();
        let after = line[at + word.len()..].chars().next();
        !before.is_some_and(is_ident_char) && !after.is_some_and(is_ident_char)
    })
}

/// `file:line: text` for every code line under `dir` naming one of `words`.
fn find_words(dir: &Path, words: &[&str], skip_tests: bool) -> Vec<String> {
    let mut hits = Vec::new();
    for f in rust_files(dir) {
        let mut src = read(&f);
        if skip_tests {
            src = without_test_code(&src);
        }
        for (n, line) in code_lines(&src) {
            for w in words {
                if has_word(&line, w) {
                    hits.push(format!("{}:{n}: `{w}` in `{}`", rel(&f), line.trim()));
                }
            }
        }
    }
    hits
}

#[test]
fn builders_never_see_rays() {
    let hits = find_words(
        &root().join("crates/builders/src"),
        &[
            "Ray",
            "RaySet",
            "WatertightRay",
            "sahara_trace",
            "sahara_traverse",
        ],
        false,
    );
    assert!(
        hits.is_empty(),
        "docs/ARCHITECTURE.md: builders never see rays (their input is triangles and a cost \
         model); remove these from crates/builders/src:\n{}\n",
        hits.join("\n")
    );
    let m = parse_manifest(&root().join("crates/builders/Cargo.toml"));
    for bad in ["sahara-traverse", "sahara-trace"] {
        assert!(
            !m.deps.contains(bad) && !m.dev_deps.contains(bad),
            "crates/builders/Cargo.toml: remove `{bad}`: builders never see rays \
             (docs/ARCHITECTURE.md)"
        );
    }
}

/// The modules of `crates/builders/src` that are not builders: what builders may use. The
/// invariant's paragraph in docs/ARCHITECTURE.md names each in backticks.
const BUILDER_SHARED_MODULES: &[&str] = &[
    "topdown",
    "split",
    "rules",
    "cost_only",
    "input",
    "simd",
    "registry",
];

#[test]
fn no_builder_imports_another() {
    let src = root().join("crates/builders/src");
    let doc = architecture();
    let invariant = doc
        .split("**Architecture invariant:** no builder module uses another")
        .nth(1)
        .and_then(|rest| rest.split("\n\n").next())
        .expect("docs/ARCHITECTURE.md: the invariant 'no builder module uses another' is missing");
    let named = backticked(invariant);
    for m in BUILDER_SHARED_MODULES {
        assert!(
            names_module(&named, m),
            "docs/ARCHITECTURE.md: the invariant 'no builder module uses another' does not name \
             the shared module `{m}` that the tidy test allows"
        );
    }
    let modules = top_level_modules(&src);
    let builders: Vec<&String> = modules
        .iter()
        .filter(|m| !BUILDER_SHARED_MODULES.contains(&m.as_str()))
        .collect();
    assert!(
        builders.len() >= 8,
        "too few builder modules found: {builders:?}"
    );
    let mut errors = Vec::new();
    for m in modules.iter().filter(|m| m.as_str() != "registry") {
        let files = if src.join(m).is_dir() {
            rust_files(&src.join(m))
        } else {
            vec![src.join(format!("{m}.rs"))]
        };
        for f in files {
            for used in crate_paths(&read(&f)) {
                if used != *m && builders.contains(&&used) {
                    errors.push(format!(
                        "{}: `{m}` uses the builder module `{used}`; move what both need into \
                         `split/`, `rules/` or the driver (docs/ARCHITECTURE.md)",
                        rel(&f)
                    ));
                }
            }
        }
    }
    assert!(errors.is_empty(), "\n{}\n", errors.join("\n"));
}

#[test]
fn metrics_never_mutate_trees() {
    let mut hits = Vec::new();
    for f in rust_files(&root().join("crates/metrics/src")) {
        for (n, line) in code_lines(&without_test_code(&read(&f))) {
            let squashed: String = line.split_whitespace().collect();
            if squashed.contains("&mutBvh") || squashed.contains("&mutsahara_bvh::Bvh") {
                hits.push(format!("{}:{n}: `{}`", rel(&f), line.trim()));
            }
        }
    }
    assert!(
        hits.is_empty(),
        "docs/ARCHITECTURE.md: metrics never mutate trees (every metric is a pure function of \
         `&Bvh`); take `&Bvh` instead of `&mut Bvh` in:\n{}\n",
        hits.join("\n")
    );
}

#[test]
fn traversal_never_knows_the_builder() {
    let m = parse_manifest(&root().join("crates/traverse/Cargo.toml"));
    assert!(
        !m.deps.contains("sahara-builders"),
        "crates/traverse/Cargo.toml: remove `sahara-builders` from [dependencies] (only its tests may \
         use it, in [dev-dependencies]): traversal never knows the builder (docs/ARCHITECTURE.md)"
    );
    // `#[cfg(test)]` modules may use the builders, which are a dev-dependency.
    let hits = find_words(
        &root().join("crates/traverse/src"),
        &["sahara_builders"],
        true,
    );
    assert!(
        hits.is_empty(),
        "docs/ARCHITECTURE.md: traversal never knows the builder; outside `#[cfg(test)]` code, \
         remove these from crates/traverse/src:\n{}\n",
        hits.join("\n")
    );
}

/// `file:line: text` for every code line of the workspace's Rust sources (`crates/`, `xtask/`,
/// `benches/`, tests and examples included) whose file is not under one of the `allowed` path
/// prefixes and for which `matches` holds. This file is skipped: it names what it looks for.
fn find_in_workspace(matches: impl Fn(&str) -> bool, allowed: &[&str]) -> Vec<String> {
    let mut hits = Vec::new();
    for dir in ["crates", "xtask", "benches"] {
        for f in rust_files(&root().join(dir)) {
            let r = rel(&f);
            if r == "xtask/src/tidy.rs" || allowed.iter().any(|a| r.starts_with(a)) {
                continue;
            }
            for (n, line) in code_lines(&read(&f)) {
                if matches(&line) {
                    hits.push(format!("{r}:{n}: `{}`", line.trim()));
                }
            }
        }
    }
    hits
}

/// Whether a line declares a struct whose name starts with `Camera` (enums such as
/// `CameraSource` name where a camera came from; they are not cameras).
fn declares_camera_type(line: &str) -> bool {
    line.match_indices("struct ").any(|(at, _)| {
        let before = line[..at].chars().next_back();
        !before.is_some_and(is_ident_char) && line[at + "struct ".len()..].starts_with("Camera")
    })
}

#[test]
fn one_camera() {
    // One camera type and one primary-ray generator: `sahara_geom::camera`. A primary-ray
    // generator is recognised by turning the field of view into the image plane's half
    // height.
    let hits = find_in_workspace(
        |l| {
            declares_camera_type(l)
                || has_word(l, "grid_rays")
                || has_word(l, "CameraGrid")
                || l.contains("fov_y_degrees.to_radians()")
        },
        &["crates/geom/src/camera.rs"],
    );
    assert!(
        hits.is_empty(),
        "docs/ARCHITECTURE.md: one camera: `sahara_geom::Camera` is the only camera type and its \
         `CameraFrame` the only primary-ray generator; use them instead of:\n{}\n",
        hits.join("\n")
    );
}

#[test]
fn nothing_reimplements_traversal() {
    // The culling interval of a closest-hit walk belongs to the kernels (and to sahara-geom,
    // which defines it and tests it).
    let mut hits = find_in_workspace(
        |l| has_word(l, "cull_distance") || has_word(l, "lower_distance"),
        &["crates/geom/", "crates/traverse/src/"],
    );
    // The binary tree's walks are in `scalar.rs` (their stack is defined in `lib.rs`).
    hits.extend(find_in_workspace(
        |l| has_word(l, "NodeStack"),
        &[
            "crates/traverse/src/lib.rs",
            "crates/traverse/src/scalar.rs",
        ],
    ));
    // The crates on the ray side above the kernels, and those below them, test no triangle.
    hits.extend(find_in_workspace(
        |l| has_word(l, "intersect_triangle"),
        // The oracle and the hard cases' own checks are the references that must share no
        // code with the kernels; the façade's scene tests its triangles in the callback it
        // hands to a kernel's walk.
        &[
            "crates/geom/",
            "crates/traverse/",
            "crates/oracle/",
            "crates/hardcases/",
            "crates/sahara/src/scene.rs",
        ],
    ));
    assert!(
        hits.is_empty(),
        "docs/ARCHITECTURE.md: nothing re-implements traversal: hits come from sahara-traverse's \
         kernels, whose binary walks are in scalar.rs; remove these:\n{}\n",
        hits.join("\n")
    );
}

#[test]
fn registry_names_are_unique_and_match_builders() {
    let entries = sahara_builders::registry::entries();
    assert!(
        !entries.is_empty(),
        "crates/builders/src/registry.rs: no builder registered"
    );
    let mut seen = BTreeSet::new();
    for e in &entries {
        assert!(
            seen.insert(e.name),
            "crates/builders/src/registry.rs: the name `{}` is registered twice; rename one preset",
            e.name
        );
        let builder = (e.make)();
        assert_eq!(
            builder.name(),
            e.name,
            "crates/builders: the registry entry `{}` makes a builder whose `Builder::name()` is \
             `{}`; make them equal (registry_entries() of its module)",
            e.name,
            builder.name()
        );
    }
}

/// The top-level modules of a `src/` directory: `foo.rs` and `foo/`, without `lib.rs` and
/// `main.rs`.
fn top_level_modules(src: &Path) -> Vec<String> {
    let mut v: Vec<String> = fs::read_dir(src)
        .unwrap_or_else(|e| panic!("cannot read {}: {e}", src.display()))
        .map(|e| e.expect("directory entry").path())
        .filter_map(|p| {
            let name = p.file_name()?.to_string_lossy().into_owned();
            if p.is_dir() {
                Some(name)
            } else {
                let stem = name.strip_suffix(".rs")?;
                (stem != "lib" && stem != "main").then(|| stem.to_string())
            }
        })
        .collect();
    v.sort();
    v.dedup();
    v
}

/// Whether a backticked span names module `m`: `` `m` ``, `` `m.rs` ``, `` `m/…` `` or
/// `` `m::…` ``.
fn names_module(spans: &[String], m: &str) -> bool {
    spans.iter().any(|s| {
        s == m
            || s == &format!("{m}.rs")
            || s.starts_with(&format!("{m}/"))
            || s.starts_with(&format!("{m}::"))
    })
}

#[test]
fn code_map_names_every_crate_and_module() {
    let doc = architecture();
    let mut errors = Vec::new();
    let mut sections = Vec::new();
    for dir in crate_dirs() {
        let heading = format!("### `crates/{dir}`");
        let found = doc
            .lines()
            .find(|l| l.starts_with(&heading))
            .and_then(|l| doc_section(&doc, l));
        match found {
            Some(s) => sections.push((format!("crates/{dir}"), s)),
            None => errors.push(format!(
                "docs/ARCHITECTURE.md: no code-map section for crates/{dir}; add \
                 \"### `crates/{dir}` — `<package name>`\" describing it"
            )),
        }
    }
    match doc_section(&doc, "### `xtask`") {
        Some(s) => sections.push(("xtask".to_string(), s)),
        None => errors.push("docs/ARCHITECTURE.md: no \"### `xtask`\" section".to_string()),
    }
    for (dir, section) in sections {
        let spans = backticked(section);
        for m in top_level_modules(&root().join(&dir).join("src")) {
            if !names_module(&spans, &m) {
                errors.push(format!(
                    "docs/ARCHITECTURE.md: the section of {dir} does not name its module `{m}` \
                     ({dir}/src/{m}); add a phrase saying what it is, with `{m}` in backticks"
                ));
            }
        }
    }
    assert!(errors.is_empty(), "\n{}\n", errors.join("\n"));
}

/// Existing absolute paths, each legitimate: (file, the whole line, trimmed).
const ABSOLUTE_PATH_ALLOW_LIST: &[(&str, &str)] = &[];

/// Whether a line contains `/work/`, `/root/`, `/home/` or `/tmp/` followed by a letter.
fn has_absolute_path(line: &str) -> bool {
    ["/work/", "/root/", "/home/", "/tmp/"].iter().any(|p| {
        line.match_indices(p).any(|(at, _)| {
            line[at + p.len()..]
                .chars()
                .next()
                .is_some_and(|c| c.is_ascii_alphabetic())
        })
    })
}

#[test]
fn no_absolute_machine_paths() {
    let out = std::process::Command::new("git")
        .arg("ls-files")
        .arg("-z")
        .current_dir(root())
        .output()
        .expect("git ls-files runs");
    assert!(out.status.success(), "git ls-files failed");
    let mut hits = Vec::new();
    for name in out.stdout.split(|&b| b == 0).filter(|n| !n.is_empty()) {
        let name = String::from_utf8_lossy(name).into_owned();
        // This file holds the allow-list itself.
        if name == "Cargo.lock" || name.ends_with("/Cargo.lock") || name == "xtask/src/tidy.rs" {
            continue;
        }
        let Ok(bytes) = fs::read(root().join(&name)) else {
            continue; // deleted in the work tree
        };
        if bytes.contains(&0) {
            continue; // binary
        }
        let Ok(text) = String::from_utf8(bytes) else {
            continue; // binary
        };
        for (i, line) in text.lines().enumerate() {
            if has_absolute_path(line)
                && !ABSOLUTE_PATH_ALLOW_LIST.contains(&(name.as_str(), line.trim()))
            {
                hits.push(format!("{name}:{}: {}", i + 1, line.trim()));
            }
        }
    }
    assert!(
        hits.is_empty(),
        "absolute machine paths (use paths relative to the workspace, an environment variable \
         or the scene catalog; a documented example goes into ABSOLUTE_PATH_ALLOW_LIST of \
         xtask/src/tidy.rs with a comment):\n{}\n",
        hits.join("\n")
    );
}

#[test]
fn readme_examples_are_doctests() {
    let mut errors = Vec::new();
    for dir in crate_dirs() {
        let readme = root().join("crates").join(&dir).join("README.md");
        if !readme.is_file() || !read(&readme).contains("```rust") {
            continue;
        }
        let lib = root().join("crates").join(&dir).join("src/lib.rs");
        let src = read(&lib);
        let included = src.contains("#![doc = include_str!(\"../README.md\")]")
            || (src.contains("#[cfg(doctest)]")
                && src.contains("#[doc = include_str!(\"../README.md\")]"));
        if !included {
            errors.push(format!(
                "{}: crates/{dir}/README.md has a ```rust example but is not compiled; add\n    \
                 #[cfg(doctest)]\n    #[doc = include_str!(\"../README.md\")]\n    \
                 struct ReadmeDoctests;",
                rel(&lib)
            ));
        }
    }
    assert!(errors.is_empty(), "\n{}\n", errors.join("\n\n"));
}

/// Whether a manifest says `publish = false`.
fn is_unpublished(manifest: &str) -> bool {
    manifest
        .lines()
        .any(|l| l.split_whitespace().collect::<String>() == "publish=false")
}

#[test]
fn library_crates_are_publishable() {
    let mut errors = Vec::new();
    let unpublished: BTreeSet<String> = manifests()
        .iter()
        .filter(|p| is_unpublished(&read(p)))
        .map(|p| parse_manifest(p).name)
        .collect();
    for path in manifests() {
        let text = read(&path);
        let name = rel(&path);
        if text
            .lines()
            .any(|l| l.trim_start().starts_with("repository"))
        {
            errors.push(format!(
                "{name}: remove `repository` (no invented URL; add it when there is a real one)"
            ));
        }
        if is_unpublished(&text) {
            continue;
        }
        let has_key = |key: &str| {
            text.lines()
                .any(|l| l.split('=').next().is_some_and(|k| k.trim() == key))
        };
        for key in ["description", "readme", "keywords", "categories"] {
            if !has_key(key) {
                errors.push(format!(
                    "{name}: a published crate needs `{key}` in [package]"
                ));
            }
        }
        if !text.contains("[package.metadata.docs.rs]") {
            errors.push(format!("{name}: add a [package.metadata.docs.rs] table"));
        }
        let dir = path.parent().expect("manifest in a folder");
        if !dir.join("README.md").is_file() {
            errors.push(format!("{name}: a published crate needs a README.md"));
        }
        for dep in &parse_manifest(&path).deps {
            if unpublished.contains(dep) {
                errors.push(format!(
                    "{name}: [dependencies] has `{dep}`, which is `publish = false`; only \
                     [dev-dependencies] may use it"
                ));
            }
        }
    }
    // Unpublished crates have no version in [workspace.dependencies], so that cargo drops
    // them from the packaged manifests of the crates that use them in their tests.
    let workspace = read(&root().join("Cargo.toml"));
    for line in workspace.lines() {
        let key = line.split('=').next().unwrap_or("").trim();
        if unpublished.contains(key) && line.contains("version") {
            errors.push(format!(
                "Cargo.toml: `{key}` is `publish = false`; give it a path and no version in \
                 [workspace.dependencies]"
            ));
        }
    }
    if workspace
        .lines()
        .any(|l| l.trim_start().starts_with("repository"))
    {
        errors.push("Cargo.toml: remove `repository` from [workspace.package]".to_string());
    }
    assert!(errors.is_empty(), "\n{}\n", errors.join("\n"));
}

/// The xtask's commands from `xtask/src/main.rs`: (subcommand variant, module), one per arm
/// `Cmd::Variant… => module::…` of its dispatch.
fn xtask_commands() -> Vec<(String, String)> {
    let main = read(&root().join("xtask/src/main.rs"));
    let mut v = Vec::new();
    for (_, line) in code_lines(&main) {
        let Some((arm, call)) = line.split_once("=>") else {
            continue;
        };
        let Some(variant) = arm.trim().strip_prefix("Cmd::") else {
            continue;
        };
        let variant: String = variant.chars().take_while(|&c| is_ident_char(c)).collect();
        let module: String = call
            .trim()
            .chars()
            .take_while(|&c| is_ident_char(c))
            .collect();
        if call.trim()[module.len()..].starts_with("::") {
            v.push((variant, module));
        }
    }
    v
}

/// `CamelCase` as `snake_case`.
fn snake_case(name: &str) -> String {
    let mut s = String::new();
    for (i, c) in name.chars().enumerate() {
        if c.is_uppercase() && i > 0 {
            s.push('_');
        }
        s.extend(c.to_lowercase());
    }
    s
}

/// The top-level modules a source names through `crate::` paths: `crate::m::…`, and each
/// first name of a group `crate::{a, b::c, …}` (comments left out).
fn crate_paths(src: &str) -> BTreeSet<String> {
    let code: String = code_lines(src).into_iter().map(|(_, l)| l + "\n").collect();
    let mut used = BTreeSet::new();
    for (at, _) in code.match_indices("crate::") {
        if code[..at].chars().next_back().is_some_and(is_ident_char) {
            continue; // `sahara_crate::` and the like
        }
        let rest = &code[at + "crate::".len()..];
        if let Some(group) = rest.strip_prefix('{') {
            let mut depth = 0usize;
            let mut item = String::new();
            let mut items = Vec::new();
            for c in group.chars() {
                match c {
                    '{' => depth += 1,
                    '}' if depth == 0 => break,
                    '}' => depth -= 1,
                    ',' if depth == 0 => items.push(std::mem::take(&mut item)),
                    _ if depth == 0 => item.push(c),
                    _ => {}
                }
            }
            items.push(item);
            for i in items {
                let name: String = i.trim().chars().take_while(|&c| is_ident_char(c)).collect();
                if !name.is_empty() {
                    used.insert(name);
                }
            }
        } else {
            let name: String = rest.chars().take_while(|&c| is_ident_char(c)).collect();
            used.insert(name);
        }
    }
    used
}

#[test]
fn crate_paths_are_read_from_uses_and_groups() {
    let src = "use crate::{engine::{self, Engine}, util};\nuse crate::tree::Series; // crate::eval\nlet x = crate::trace::run(a);\n";
    let want: BTreeSet<String> = ["engine", "trace", "tree", "util"].map(String::from).into();
    assert_eq!(crate_paths(src), want);
    assert_eq!(snake_case("ReinsertRays"), "reinsert_rays");
}

#[test]
fn no_command_module_uses_another() {
    let src = root().join("xtask/src");
    let commands = xtask_commands();
    let mut errors = Vec::new();
    assert!(
        commands.len() >= 10,
        "xtask/src/main.rs: the dispatch `Cmd::… => module::run(…)` was not found ({commands:?})"
    );
    for (variant, module) in &commands {
        if snake_case(variant) != *module {
            errors.push(format!(
                "xtask/src/main.rs: the command `{variant}` runs in the module `{module}`; name \
                 the module after the command (`{}`), with no suffix (docs/ARCHITECTURE.md, \
                 xtask)",
                snake_case(variant)
            ));
        }
    }
    let is_command = |m: &str| commands.iter().any(|(_, c)| c == m);
    // This file is a test, not a module of the program (and its examples name commands).
    for m in top_level_modules(&src).into_iter().filter(|m| m != "tidy") {
        let files = if src.join(&m).is_dir() {
            rust_files(&src.join(&m))
        } else {
            vec![src.join(format!("{m}.rs"))]
        };
        for f in files {
            for used in crate_paths(&read(&f)) {
                if used == m || !is_command(&used) {
                    continue;
                }
                errors.push(if is_command(&m) {
                    format!(
                        "{}: the command module `{m}` uses the command module `{used}`; move \
                         what both need into a shared module (`util`, `engine`, `tree`, …; \
                         docs/ARCHITECTURE.md, xtask)",
                        rel(&f)
                    )
                } else {
                    format!(
                        "{}: the shared module `{m}` uses the command module `{used}`; shared \
                         modules use no command (docs/ARCHITECTURE.md, xtask)",
                        rel(&f)
                    )
                });
            }
        }
    }
    assert!(errors.is_empty(), "\n{}\n", errors.join("\n"));
}
