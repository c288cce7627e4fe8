//! The workspace's shape, checked: which crate may depend on which (the data
//! flow runs one way), no import cycle between the modules of any crate, and
//! the same third-party features for the binary and the Python binding.
//! ARCHITECTURE.md states the same rules in prose; this test fails when the
//! code and that page part ways: a path it names that is gone, a crate it
//! calls a leaf that depends on another, a long file it gives no reason for,
//! a recipe that leaves out a file its kind of change last touched.

use std::collections::{BTreeMap, BTreeSet};
use std::path::{Path, PathBuf};
use std::process::Command;

#[path = "common/pages.rs"]
mod pages;

/// Each workspace crate and the workspace crates it may depend on (normal or
/// build dependencies; tests and benchmarks may use anything). Read it as
/// the data flow: a crate sees only the stages before it and the leaves.
const ALLOWED: &[(&str, &[&str])] = &[
    // Leaves: one job each, nothing of the rest of acq.
    // The GUM's arithmetic: budgets and calibration curves.
    ("acq-metrology", &[]),
    // The one error of the commands, by kind.
    ("acq-error", &[]),
    // Frames, log formats and the CAN protocols.
    ("acq-can", &[]),
    ("acq-twins", &[]),
    ("acq-algorithms", &[]),
    ("acq-report", &[]),
    // No code: the third-party features the binary and the binding share.
    ("acq-shared-features", &[]),
    // Where a model run happens: an argv, a directory, a time limit.
    ("acq-exec", &[]),
    // The rig file and frames -> samples through it; a sensor's
    // certificate points become its conversion through acq-metrology's
    // curve.
    ("acq-rig", &["acq-can", "acq-metrology"]),
    // Files in and out, on top of the log and rig formats.
    ("acq-io", &["acq-error", "acq-can", "acq-rig"]),
    // Live buses; knows nothing of analysis.
    (
        "acq-acquire",
        &["acq-can", "acq-rig", "acq-error", "acq-io"],
    ),
    // Offline analysis; knows nothing of live buses.
    (
        "acq-analysis",
        &["acq-can", "acq-rig", "acq-error", "acq-io", "acq-metrology"],
    ),
    // A calibration study on any model: no twin, no CAN, no command line.
    (
        "acq-study",
        &[
            "acq-metrology",
            "acq-error",
            "acq-io",
            "acq-analysis",
            "acq-report",
            "acq-algorithms",
            "acq-exec",
        ],
    ),
    // The twins' studies and the presets: measured values in, twins and
    // the engine run, reports out; no CAN.
    (
        "acq-workflows",
        &[
            "acq-metrology",
            "acq-error",
            "acq-io",
            "acq-analysis",
            "acq-report",
            "acq-twins",
            "acq-algorithms",
            "acq-exec",
            "acq-study",
        ],
    ),
    // The live page: frames, samples and measured values, read only.
    (
        "acq-view",
        &[
            "acq-can",
            "acq-rig",
            "acq-error",
            "acq-io",
            "acq-acquire",
            "acq-analysis",
            "acq-report",
        ],
    ),
    // A campaign's lake: recordings decoded and measured values extracted
    // into Parquet files; no loss, no model, no CAN of its own. A backlog's
    // slices run as jobs of the executor (acq lake ingest --slurm).
    (
        "acq-lake",
        &["acq-rig", "acq-error", "acq-io", "acq-analysis", "acq-exec"],
    ),
    // The demo composes the whole chain.
    (
        "acq-demo",
        &[
            "acq-can",
            "acq-rig",
            "acq-error",
            "acq-io",
            "acq-acquire",
            "acq-analysis",
            "acq-report",
            "acq-workflows",
            "acq-view",
        ],
    ),
    // The Python package's binding: glue, like the binary, over the
    // libraries a notebook calls.
    (
        "acq-python",
        &[
            "acq-algorithms",
            "acq-can",
            "acq-rig",
            "acq-error",
            "acq-io",
            "acq-analysis",
            "acq-study",
            "acq-twins",
            "acq-workflows",
            "acq-shared-features",
        ],
    ),
    // The binary is glue over all of them.
    (
        "acq",
        &[
            "acq-metrology",
            "acq-can",
            "acq-rig",
            "acq-twins",
            "acq-algorithms",
            "acq-error",
            "acq-io",
            "acq-acquire",
            "acq-analysis",
            "acq-report",
            "acq-exec",
            "acq-study",
            "acq-workflows",
            "acq-demo",
            "acq-view",
            "acq-lake",
            "acq-shared-features",
        ],
    ),
];

fn workspace_root() -> PathBuf {
    PathBuf::from(env!("CARGO_MANIFEST_DIR"))
}

struct Package {
    name: String,
    src_dir: PathBuf,
    /// Workspace crates it depends on, outside dev-dependencies.
    workspace_deps: BTreeSet<String>,
    /// Every crate it depends on, outside dev-dependencies.
    deps: BTreeSet<String>,
}

/// What `cargo ARGS --offline` prints in the workspace; fails the test with
/// cargo's own message when it fails.
fn cargo_output(args: &[&str]) -> Vec<u8> {
    let cargo = std::env::var("CARGO").unwrap_or_else(|_| "cargo".into());
    let output = Command::new(cargo)
        .args(args)
        .arg("--offline")
        .current_dir(workspace_root())
        .output()
        .expect("cargo runs");
    assert!(
        output.status.success(),
        "cargo {} failed: {}",
        args.join(" "),
        String::from_utf8_lossy(&output.stderr)
    );
    output.stdout
}

fn workspace_packages() -> Vec<Package> {
    let metadata = cargo_output(&["metadata", "--format-version", "1", "--no-deps"]);
    let metadata: serde_json::Value = serde_json::from_slice(&metadata).unwrap();
    let packages = metadata["packages"].as_array().unwrap();
    let names: BTreeSet<String> = packages
        .iter()
        .map(|p| p["name"].as_str().unwrap().to_string())
        .collect();
    packages
        .iter()
        .map(|p| {
            let manifest = PathBuf::from(p["manifest_path"].as_str().unwrap());
            let deps: BTreeSet<String> = p["dependencies"]
                .as_array()
                .unwrap()
                .iter()
                .filter(|d| d["kind"].as_str() != Some("dev"))
                .map(|d| d["name"].as_str().unwrap().to_string())
                .collect();
            let workspace_deps = deps
                .iter()
                .filter(|name| names.contains(*name))
                .cloned()
                .collect();
            Package {
                name: p["name"].as_str().unwrap().to_string(),
                src_dir: manifest.parent().unwrap().join("src"),
                workspace_deps,
                deps,
            }
        })
        .collect()
}

/// Each third-party crate in `package`'s dependency graph (normal and build
/// edges, proc-macros included) with the features cargo turns on for it.
fn features_in_graph_of(package: &str) -> BTreeMap<String, BTreeSet<String>> {
    features_in_tree(&["-p", package, "-e", "normal,build"])
}

/// The features of each third-party crate in `cargo tree ARGS`.
fn features_in_tree(args: &[&str]) -> BTreeMap<String, BTreeSet<String>> {
    let mut command = vec!["tree"];
    command.extend_from_slice(args);
    command.extend_from_slice(&["--prefix", "none", "--format", "{p}|{f}"]);
    let tree = cargo_output(&command);
    let mut features: BTreeMap<String, BTreeSet<String>> = BTreeMap::new();
    for line in String::from_utf8_lossy(&tree).lines() {
        let Some((crate_and_version, on)) = line.split_once('|') else {
            continue;
        };
        // "name v1.2.3 (/path)" for a workspace crate, "name v1.2.3" else.
        if crate_and_version.contains('(') {
            continue;
        }
        let on = on.trim_end_matches(" (*)");
        features
            .entry(crate_and_version.trim().to_string())
            .or_default()
            .extend(on.split(',').filter(|f| !f.is_empty()).map(String::from));
    }
    features
}

/// `pip install ./python` after `cargo build --release` reuses the build
/// only when both graphs ask for the same features of every crate they
/// share (cargo keys a build by its features).
#[test]
fn the_binary_and_the_binding_ask_for_the_same_features() {
    let binary = features_in_graph_of("acq");
    let binding = features_in_graph_of("acq-python");
    let differing = differing_features(("binary's", &binary), ("binding's", &binding));
    assert!(
        differing.is_empty(),
        "add the union of these features to shared-features/Cargo.toml \
         (proc-macro crates' dependencies under [build-dependencies]):\n{}",
        differing.join("\n")
    );
    // The comparison saw the crates both graphs hold.
    assert!(binary.keys().any(|k| k.starts_with("serde v")));
    assert!(binding.keys().any(|k| k.starts_with("arrow-array v")));
}

/// The tests' build (scripts/test: every target of the workspace, its
/// dev-dependencies too) reuses the demo's release build of a crate only
/// when both ask for the same features of it; a dev-dependency that asks
/// for one more feature of a crate the binary uses (tempfile of rustix's
/// `fs`) had the tests' build compile that crate and every workspace crate
/// above it a second time.
#[test]
fn the_binary_and_the_tests_ask_for_the_same_features() {
    let binary = features_in_graph_of("acq");
    let tests = features_in_tree(&["--workspace", "-e", "normal,build,dev"]);
    let differing = differing_features(("binary's", &binary), ("tests'", &tests));
    assert!(
        differing.is_empty(),
        "add the union of these features to shared-features/Cargo.toml:\n{}",
        differing.join("\n")
    );
    assert!(tests.keys().any(|k| k.starts_with("tempfile v")));
    // Shown to fail when broken: a crate whose features differ is named.
    let mut fewer = binary.clone();
    let rustix = fewer
        .keys()
        .find(|k| k.starts_with("rustix v"))
        .cloned()
        .expect("the binary uses rustix");
    fewer.get_mut(&rustix).unwrap().remove("fs");
    let broken = differing_features(("binary's", &fewer), ("tests'", &tests));
    assert!(
        broken.iter().any(|line| line.starts_with("rustix v")),
        "{broken:?}"
    );
}

/// "crate: the A's {features}, the B's {features}" (names given with
/// their possessive) for each crate both
/// graphs hold with different features.
fn differing_features(
    (a_name, a): (&str, &BTreeMap<String, BTreeSet<String>>),
    (b_name, b): (&str, &BTreeMap<String, BTreeSet<String>>),
) -> Vec<String> {
    a.iter()
        .filter_map(|(name, on_for_a)| {
            let on_for_b = b.get(name)?;
            (on_for_a != on_for_b)
                .then(|| format!("{name}: the {a_name} {on_for_a:?}, the {b_name} {on_for_b:?}"))
        })
        .collect()
}

#[test]
fn every_crate_depends_only_on_the_stages_before_it() {
    let allowed: BTreeMap<&str, &[&str]> = ALLOWED.iter().copied().collect();
    let packages = workspace_packages();
    let mut problems = Vec::new();
    for package in &packages {
        let Some(may_use) = allowed.get(package.name.as_str()) else {
            problems.push(format!(
                "{} is not in tests/architecture.rs ALLOWED: add it with the crates it may use, and a row in ARCHITECTURE.md",
                package.name
            ));
            continue;
        };
        for dep in &package.workspace_deps {
            if !may_use.contains(&dep.as_str()) {
                problems.push(format!(
                    "{} depends on {dep}, against the data flow (ARCHITECTURE.md, Invariants)",
                    package.name
                ));
            }
        }
    }
    assert!(problems.is_empty(), "{}", problems.join("\n"));
    // The table names no crate that is gone.
    let names: BTreeSet<&str> = packages.iter().map(|p| p.name.as_str()).collect();
    for (name, _) in ALLOWED {
        assert!(
            names.contains(name),
            "ALLOWED names {name}, not in the workspace"
        );
    }
}

#[test]
fn no_crate_has_an_import_cycle_between_its_modules() {
    let mut problems = Vec::new();
    for package in workspace_packages() {
        let graph = ModuleGraph::read(&package.src_dir);
        assert!(
            graph.modules.len() > 1
                || [
                    "acq-error",
                    "acq-report",
                    "acq-python",
                    "acq-shared-features"
                ]
                .contains(&package.name.as_str()),
            "{}: found no modules in {}",
            package.name,
            package.src_dir.display()
        );
        for cycle in graph.cycles() {
            problems.push(format!("{}: {}", package.name, cycle.join(" -> ")));
        }
    }
    assert!(
        problems.is_empty(),
        "import cycles (move the shared types into a module both sides use):\n{}",
        problems.join("\n")
    );
}

#[test]
fn the_cycle_check_sees_a_cycle() {
    // The check itself: a parent that uses its child, which uses the parent.
    let dir = tempfile::tempdir().unwrap();
    let src = dir.path();
    std::fs::create_dir_all(src.join("log")).unwrap();
    std::fs::write(src.join("lib.rs"), "pub mod log;\n").unwrap();
    std::fs::write(
        src.join("log/mod.rs"),
        "pub mod asc;\nuse asc::AscReader;\npub struct Record;\n",
    )
    .unwrap();
    std::fs::write(
        src.join("log/asc.rs"),
        "use super::Record;\npub struct AscReader;\n",
    )
    .unwrap();
    let cycle = ModuleGraph::read(src).find_cycle().expect("a cycle");
    assert!(cycle.contains(&"log".to_string()) && cycle.contains(&"log::asc".to_string()));
    // Moving the shared type into a sibling breaks it.
    std::fs::write(
        src.join("log/mod.rs"),
        "pub mod asc;\npub mod record;\nuse asc::AscReader;\n",
    )
    .unwrap();
    std::fs::write(src.join("log/record.rs"), "pub struct Record;\n").unwrap();
    std::fs::write(
        src.join("log/asc.rs"),
        "use super::record::Record;\npub struct AscReader;\n",
    )
    .unwrap();
    assert_eq!(ModuleGraph::read(src).find_cycle(), None);
    // Siblings through a crate path, two levels down, are seen too.
    std::fs::write(src.join("lib.rs"), "pub mod log;\npub mod cli;\n").unwrap();
    std::fs::write(src.join("cli.rs"), "use crate::{log::asc, self as me};\n").unwrap();
    std::fs::write(
        src.join("log/record.rs"),
        "pub struct Record(crate::cli::X);\n",
    )
    .unwrap();
    let cycle = ModuleGraph::read(src).find_cycle().expect("a cycle");
    assert!(cycle.contains(&"cli".to_string()), "{cycle:?}");
}

/// The modules of one crate (by file: `a.rs` or `a/mod.rs` is `a`) and
/// which uses which. An edge between two modules in different subtrees is
/// also counted between the subtrees' roots under their common parent, so a
/// cycle through several files shows at the level where it closes. The crate
/// root is left out (see [`ModuleGraph::add_edge`]).
struct ModuleGraph {
    modules: BTreeSet<String>,
    edges: BTreeMap<String, BTreeSet<String>>,
}

impl ModuleGraph {
    fn read(src_dir: &Path) -> Self {
        let mut files = Vec::new();
        collect_rs_files(src_dir, &mut files);
        let mut modules = BTreeSet::new();
        let mut sources = Vec::new();
        for file in files {
            let relative = file.strip_prefix(src_dir).unwrap();
            let module = module_of(relative);
            modules.insert(module.clone());
            sources.push((module, std::fs::read_to_string(&file).unwrap()));
        }
        let mut graph = ModuleGraph {
            modules,
            edges: BTreeMap::new(),
        };
        for (module, text) in &sources {
            // Unit tests (at the end of a file) may use anything of their module.
            let code = text.split("#[cfg(test)]").next().unwrap();
            for target in graph.references(module, code) {
                graph.add_edge(module, &target);
            }
        }
        graph
    }

    /// The modules `code`, written in `module`, names: through `crate::`,
    /// `super::`, `self::` or a child module's name.
    fn references(&self, module: &str, code: &str) -> BTreeSet<String> {
        let code = strip_comments(code);
        let mut found = BTreeSet::new();
        for (start, _) in code.match_indices("::") {
            // The whole path this `::` belongs to, from its first segment.
            let before = &code[..start];
            let head_start = before
                .rfind(|c: char| !(c.is_alphanumeric() || c == '_' || c == ':'))
                .map_or(0, |i| i + 1);
            if code[head_start..].starts_with("::") || start != path_first_sep(&code, head_start) {
                continue;
            }
            let path_text = &code[head_start..];
            for path in expand_path(path_text) {
                if let Some(target) = self.resolve(module, &path) {
                    found.insert(target);
                }
            }
        }
        found
    }

    /// The module a path names, relative to `module`, or `None` for a path
    /// outside the crate.
    fn resolve(&self, module: &str, path: &[String]) -> Option<String> {
        let mut base: Vec<String> = split_module(module);
        let mut segments = path.iter().peekable();
        match segments.peek().map(|s| s.as_str()) {
            Some("crate") => {
                base.clear();
                segments.next();
            }
            Some("super") => {
                while segments.peek().map(|s| s.as_str()) == Some("super") {
                    base.pop();
                    segments.next();
                }
            }
            Some("self") => {
                segments.next();
            }
            Some(first) => {
                let mut child = base.clone();
                child.push(first.to_string());
                if !self.modules.contains(&child.join("::")) {
                    return None;
                }
            }
            None => return None,
        }
        let mut resolved = base.join("::");
        for segment in segments {
            let mut next = split_module(&resolved);
            next.push(segment.clone());
            let candidate = next.join("::");
            if self.modules.contains(&candidate) {
                resolved = candidate;
            } else {
                break;
            }
        }
        Some(resolved)
    }

    /// The crate root (`lib.rs`, `main.rs`) is the table of contents: it
    /// declares and re-exports every module, so edges to or from it say
    /// nothing about layering and are left out.
    fn add_edge(&mut self, from: &str, to: &str) {
        if from.is_empty() || to.is_empty() {
            return;
        }
        let from_path = split_module(from);
        let to_path = split_module(to);
        let common = from_path
            .iter()
            .zip(&to_path)
            .take_while(|(a, b)| a == b)
            .count();
        let from_top = from_path[..(common + 1).min(from_path.len())].join("::");
        let to_top = to_path[..(common + 1).min(to_path.len())].join("::");
        for (a, b) in [(from.to_string(), to.to_string()), (from_top, to_top)] {
            if a != b {
                self.edges.entry(a).or_default().insert(b);
            }
        }
    }

    /// One cycle, as the modules around it, if there is any.
    fn find_cycle(&self) -> Option<Vec<String>> {
        self.cycles().into_iter().next()
    }

    /// A cycle through each group of modules that reach each other.
    fn cycles(&self) -> Vec<Vec<String>> {
        let mut cycles = Vec::new();
        let mut seen = BTreeSet::new();
        for start in self.edges.keys() {
            if seen.contains(start) {
                continue;
            }
            // The shortest way back to `start` (breadth first), if any.
            let mut previous: BTreeMap<&str, &str> = BTreeMap::new();
            let mut queue = std::collections::VecDeque::from([start.as_str()]);
            let mut closing = None;
            while let Some(node) = queue.pop_front() {
                for next in self.edges.get(node).into_iter().flatten() {
                    if next == start {
                        closing = Some(node);
                        break;
                    }
                    if !previous.contains_key(next.as_str()) {
                        previous.insert(next, node);
                        queue.push_back(next);
                    }
                }
                if closing.is_some() {
                    break;
                }
            }
            if let Some(closing) = closing {
                let mut way_back = Vec::new();
                let mut node = closing;
                while node != start {
                    way_back.push(node.to_string());
                    node = previous[node];
                }
                way_back.reverse();
                let mut cycle = vec![start.clone()];
                cycle.extend(way_back);
                cycle.push(start.clone());
                seen.extend(cycle.iter().cloned());
                cycles.push(cycle);
            }
        }
        cycles
    }
}

fn split_module(module: &str) -> Vec<String> {
    if module.is_empty() {
        Vec::new()
    } else {
        module.split("::").map(str::to_string).collect()
    }
}

/// Where the first `::` of the path starting at `start` is.
fn path_first_sep(code: &str, start: usize) -> usize {
    code[start..].find("::").map_or(usize::MAX, |i| start + i)
}

/// `a::b::{c, d::e}` -> [a, b, c], [a, b, d, e]: the paths one `use` or
/// expression names (only the first level of braces, which is all this
/// code base writes).
fn expand_path(text: &str) -> Vec<Vec<String>> {
    let mut prefix = Vec::new();
    let mut rest = text;
    loop {
        let end = rest
            .find(|c: char| !(c.is_alphanumeric() || c == '_'))
            .unwrap_or(rest.len());
        let segment = &rest[..end];
        if segment.is_empty() {
            break;
        }
        prefix.push(segment.to_string());
        rest = &rest[end..];
        if let Some(after) = rest.strip_prefix("::") {
            rest = after;
            if let Some(group) = rest.strip_prefix('{') {
                let close = group.find('}').unwrap_or(group.len());
                return group[..close]
                    .split(',')
                    .map(str::trim)
                    .filter(|item| !item.is_empty())
                    .map(|item| {
                        let mut path = prefix.clone();
                        path.extend(
                            item.split("::")
                                .map(|s| s.split_whitespace().next().unwrap_or("").to_string())
                                .filter(|s| !s.is_empty() && s != "self" && s != "*"),
                        );
                        path
                    })
                    .collect();
            }
        } else {
            break;
        }
    }
    vec![prefix]
}

/// The code without comments and without re-exports: `pub use child::X`
/// in a parent names the child's item for the parent's users, it is no use
/// of the child by the parent.
fn strip_comments(code: &str) -> String {
    let mut in_reexport = false;
    code.lines()
        .map(|line| {
            let trimmed = line.trim_start();
            if trimmed.starts_with("pub use ") || trimmed.starts_with("pub(crate) use ") {
                in_reexport = true;
            }
            if in_reexport {
                in_reexport = !line.trim_end().ends_with(';');
                return "";
            }
            match line.find("//") {
                Some(i) => &line[..i],
                None => line,
            }
        })
        .collect::<Vec<_>>()
        .join("\n")
}

fn module_of(relative: &Path) -> String {
    let mut parts: Vec<String> = relative
        .iter()
        .map(|p| p.to_string_lossy().into_owned())
        .collect();
    let file = parts.pop().unwrap();
    let stem = file.trim_end_matches(".rs");
    if !matches!(stem, "mod" | "lib" | "main") {
        parts.push(stem.to_string());
    }
    parts.join("::")
}

fn collect_rs_files(dir: &Path, files: &mut Vec<PathBuf>) {
    let Ok(entries) = std::fs::read_dir(dir) else {
        return;
    };
    for entry in entries.flatten() {
        let path = entry.path();
        if path.is_dir() {
            collect_rs_files(&path, files);
        } else if path.extension().is_some_and(|e| e == "rs") {
            files.push(path);
        }
    }
    files.sort();
}

fn project_pages() -> Vec<PathBuf> {
    pages::project_pages(&workspace_root())
}

/// The link targets of a Markdown page, outside code blocks and spans.
fn link_targets(markdown: &str) -> Vec<String> {
    let mut targets = Vec::new();
    let mut in_fence = false;
    for line in markdown.lines() {
        if line.trim_start().starts_with("```") {
            in_fence = !in_fence;
            continue;
        }
        if in_fence {
            continue;
        }
        // Drop code spans: a link inside one is text.
        let prose: String = line
            .split('`')
            .enumerate()
            .filter(|(i, _)| i % 2 == 0)
            .map(|(_, part)| part)
            .collect::<Vec<_>>()
            .join(" ");
        let mut rest = prose.as_str();
        while let Some(start) = rest.find("](") {
            let after = &rest[start + 2..];
            let Some(end) = after.find(')') else { break };
            targets.push(after[..end].trim().to_string());
            rest = &after[end..];
        }
    }
    targets
}

/// A heading's anchor as mdBook and GitHub make it: lower case, letters,
/// digits, '_' and '-' kept, white space to '-', the rest dropped.
fn anchor_of(heading: &str) -> String {
    heading
        .trim()
        .chars()
        .filter_map(|c| {
            if c.is_alphanumeric() || c == '_' || c == '-' {
                Some(c.to_lowercase().next().unwrap_or(c))
            } else if c.is_whitespace() {
                Some('-')
            } else {
                None
            }
        })
        .collect()
}

/// The anchors of a page's headings, outside code blocks.
fn anchors_of(markdown: &str) -> BTreeSet<String> {
    let mut in_fence = false;
    let mut anchors = BTreeSet::new();
    for line in markdown.lines() {
        if line.trim_start().starts_with("```") {
            in_fence = !in_fence;
        } else if !in_fence && line.starts_with('#') {
            anchors.insert(anchor_of(line.trim_start_matches('#')));
        }
    }
    anchors
}

#[test]
fn a_heading_s_anchor_is_the_one_mdbook_makes() {
    assert_eq!(
        anchor_of(" Parquet and MF4 output"),
        "parquet-and-mf4-output"
    );
    assert_eq!(
        anchor_of(" A study at the rig: `--study`"),
        "a-study-at-the-rig---study"
    );
    assert_eq!(
        link_targets("see [a](b.md#c) and `[x](not-a-link)` then [d](https://e)"),
        ["b.md#c", "https://e"]
    );
}

/// Every link between the project's own pages leads to a file that exists
/// and, with a `#fragment`, to a heading of it; every chapter of the guide
/// is in its table of contents. `mdbook build docs` (scripts/test) builds
/// the guide but does not check its links.
#[test]
fn every_link_between_the_project_s_pages_leads_somewhere() {
    let root = workspace_root();
    let mut dead = Vec::new();
    for page in project_pages() {
        let text = std::fs::read_to_string(&page).unwrap();
        for target in link_targets(&text) {
            if target.contains("://") || target.starts_with("mailto:") {
                continue;
            }
            let (file, fragment) = match target.split_once('#') {
                Some((file, fragment)) => (file, Some(fragment)),
                None => (target.as_str(), None),
            };
            let linked = if file.is_empty() {
                page.clone()
            } else {
                page.parent().unwrap().join(file)
            };
            let shown = page.strip_prefix(&root).unwrap_or(&page).display();
            if !linked.exists() {
                dead.push(format!("{shown}: {target}: no such file"));
                continue;
            }
            if let Some(fragment) = fragment {
                let linked_text = std::fs::read_to_string(&linked).unwrap_or_default();
                if !anchors_of(&linked_text).contains(fragment) {
                    dead.push(format!("{shown}: {target}: no heading makes #{fragment}"));
                }
            }
        }
    }
    assert!(dead.is_empty(), "dead links:\n{}", dead.join("\n"));
    let summary = std::fs::read_to_string(root.join("docs/src/SUMMARY.md")).unwrap();
    let listed: BTreeSet<String> = link_targets(&summary).into_iter().collect();
    let unlisted: Vec<String> = project_pages()
        .iter()
        .filter(|page| page.parent() == Some(root.join("docs/src").as_path()))
        .map(|page| page.file_name().unwrap().to_string_lossy().into_owned())
        .filter(|name| name != "SUMMARY.md" && !listed.contains(name))
        .collect();
    assert!(
        unlisted.is_empty(),
        "chapters missing from docs/src/SUMMARY.md: {unlisted:?}"
    );
}

/// The crates that may name clap: the binary alone. The libraries take
/// options structs; their arguments, and the conversion, are in `src/cli`
/// (ARCHITECTURE.md, "Invariants").
const MAY_NAME_CLAP: &[&str] = &["acq"];

/// Where the process may exit, and where signals may be taken: the binary.
/// A library that must stop on Ctrl-C takes a future that resolves then.
const THE_BINARY: &str = "src/";

/// The library code that creates, replaces or renames files itself instead
/// of through `acq_io::output`, each for its reason.
const WRITES_DIRECTLY: &[(&str, &str)] = &[
    (
        "io/src/",
        "acq_io::output itself, and the session file it serves",
    ),
    (
        "acquire/src/record/",
        "the recorder's raw log, written and rotated as it streams, and the session's rig copies",
    ),
    (
        "acquire/src/import.rs",
        "an imported session's raw log, moved in once whole, and the logger files copied into it byte for byte",
    ),
    (
        "lake/src/publish.rs",
        "a lake's files, moved by a rename from the scratch directory into the partitions other engines read, and its manifest entries flushed to disk before their rename",
    ),
    (
        "algorithms/src/evaluation.rs",
        "the evaluation log, appended run by run so that a crash loses none",
    ),
    (
        "study/src/part_slopes.rs",
        "each run's curve slopes beside the evaluation log, appended run by run for a resumed search",
    ),
    (
        "study/src/command_model.rs",
        "a model run's parameter file and copied inputs, in its own directory",
    ),
    (
        "exec/src/executor.rs",
        "a model run's stdout and stderr, in its own directory",
    ),
    (
        "exec/src/slurm/",
        "a job's script and the mark that acq cancelled it, in its run's directory",
    ),
    (
        "demo/src/lib.rs",
        "the mark that lets the next demo clear its own output",
    ),
];

/// Each workspace source file's non-test code (up to its first
/// `#[cfg(test)]`, where acq keeps its unit tests), by its path from the
/// workspace root.
fn non_test_sources() -> Vec<(String, String)> {
    let root = workspace_root();
    let mut sources = Vec::new();
    for package in workspace_packages() {
        let mut files = Vec::new();
        collect_rs_files(&package.src_dir, &mut files);
        for file in files {
            let text = std::fs::read_to_string(&file).unwrap();
            let code = match text.find("#[cfg(test)]") {
                Some(i) => &text[..i],
                None => &text[..],
            };
            let relative = file
                .strip_prefix(&root)
                .unwrap()
                .to_string_lossy()
                .into_owned();
            sources.push((relative, strip_comments(code)));
        }
    }
    sources
}

#[test]
fn only_the_binary_names_clap() {
    let mut offenders: Vec<String> = workspace_packages()
        .iter()
        .filter(|p| p.deps.contains("clap") && !MAY_NAME_CLAP.contains(&p.name.as_str()))
        .map(|p| format!("{} depends on clap", p.name))
        .collect();
    let may_name = |path: &str| {
        MAY_NAME_CLAP.iter().any(|name| {
            let dir = match name.strip_prefix("acq-") {
                Some(stage) => format!("{stage}/src/"),
                None => "src/".to_string(),
            };
            path.starts_with(&dir)
        })
    };
    for (path, code) in non_test_sources() {
        if code.contains("clap::") && !may_name(&path) {
            offenders.push(format!("{path} names clap"));
        }
    }
    assert!(offenders.is_empty(), "{offenders:#?}");
}

#[test]
fn only_the_binary_exits_the_process_or_takes_signals() {
    let takes_signals = ["tokio::signal", "signal_hook", "sigaction", "process::exit"];
    let offenders: Vec<String> = non_test_sources()
        .into_iter()
        .filter(|(path, _)| !path.starts_with(THE_BINARY))
        .filter_map(|(path, code)| {
            let found: Vec<&str> = takes_signals
                .iter()
                .copied()
                .filter(|call| code.contains(call))
                .collect();
            (!found.is_empty()).then(|| format!("{path}: {found:?}"))
        })
        .collect();
    assert!(
        offenders.is_empty(),
        "signals taken or the process exited outside the binary ({THE_BINARY}): {offenders:#?}"
    );
}

#[test]
fn files_are_written_through_acq_io_output_but_where_a_reason_is_listed() {
    let writes = [
        "fs::write(",
        "File::create(",
        "OpenOptions::new()",
        "fs::rename(",
        "fs::copy(",
    ];
    let offenders: Vec<String> = non_test_sources()
        .into_iter()
        .filter(|(path, _)| !WRITES_DIRECTLY.iter().any(|(p, _)| path.starts_with(p)))
        .filter_map(|(path, code)| {
            let found: Vec<&str> = writes
                .iter()
                .copied()
                .filter(|w| names_call(&code, w))
                .collect();
            (!found.is_empty()).then(|| format!("{path}: {found:?}"))
        })
        .collect();
    assert!(
        offenders.is_empty(),
        "files written other than through acq_io::output, with no reason in WRITES_DIRECTLY: {offenders:#?}"
    );
}

/// `code` calls `path` itself, not a function whose name ends like it
/// (`CompleteOnlyFile::create` is no `File::create`).
fn names_call(code: &str, path: &str) -> bool {
    code.match_indices(path).any(|(at, _)| {
        !code[..at]
            .chars()
            .next_back()
            .is_some_and(|c| c.is_alphanumeric() || c == '_')
    })
}

/// The non-test functions longer than [`LONGEST_FUNCTION_LINES`], each
/// with why it stays whole or that it is still to be split. The list only
/// shrinks (ARCHITECTURE.md, "Invariants").
const LONG_FUNCTIONS: &[(&str, &str, &str)] = &[
    ("twins/src/tensile/gtn.rs", "update_with_start", "the GTN return mapping: one Newton iteration over the yield condition, its local state, in the order of the published algorithm"),
    ("algorithms/src/optim.rs", "minimize_bounded", "the L-BFGS-B iteration: its history, the projected search and the line search share one state"),
    ("algorithms/src/least_squares.rs", "least_squares", "the Levenberg-Marquardt iteration: damping, the halved steps and the cost history share one state"),
];

/// About the longest a function reads whole on one screen and a half.
const LONGEST_FUNCTION_LINES: usize = 120;

/// The braces and semicolons of `code` outside comments, strings and
/// character literals, with their line numbers (from 1).
fn structure_of(code: &str) -> Vec<(usize, char)> {
    let chars: Vec<char> = code.chars().collect();
    let (mut i, mut line, mut found) = (0, 1, Vec::new());
    // A `;` inside square brackets is an array's length (`[f64; 2]`), not
    // the end of a declaration.
    let mut brackets = 0usize;
    let at = |i: usize| chars.get(i).copied().unwrap_or('\0');
    while i < chars.len() {
        let c = chars[i];
        match c {
            '\n' => line += 1,
            '/' if at(i + 1) == '/' => {
                while i < chars.len() && chars[i] != '\n' {
                    i += 1;
                }
                continue;
            }
            '/' if at(i + 1) == '*' => {
                i += 2;
                while i < chars.len() && !(chars[i] == '*' && at(i + 1) == '/') {
                    line += usize::from(chars[i] == '\n');
                    i += 1;
                }
                i += 2;
                continue;
            }
            'r' if (at(i + 1) == '"' || (at(i + 1) == '#' && matches!(at(i + 2), '"' | '#')))
                && !(i > 0 && (chars[i - 1].is_alphanumeric() || chars[i - 1] == '_')) =>
            {
                let mut hashes = 0;
                i += 1;
                while at(i) == '#' {
                    hashes += 1;
                    i += 1;
                }
                i += 1; // the opening quote
                loop {
                    if i >= chars.len() {
                        break;
                    }
                    if chars[i] == '"' && (1..=hashes).all(|k| at(i + k) == '#') {
                        i += 1 + hashes;
                        break;
                    }
                    line += usize::from(chars[i] == '\n');
                    i += 1;
                }
                continue;
            }
            '"' => {
                i += 1;
                while i < chars.len() && chars[i] != '"' {
                    if chars[i] == '\\' {
                        i += 1;
                    }
                    line += usize::from(at(i) == '\n');
                    i += 1;
                }
            }
            '\'' if at(i + 1) == '\\' => {
                i += 2;
                while i < chars.len() && chars[i] != '\'' {
                    i += 1;
                }
            }
            '\'' if at(i + 2) == '\'' => i += 2,
            '[' => brackets += 1,
            ']' => brackets = brackets.saturating_sub(1),
            ';' if brackets > 0 => {}
            '{' | '}' | ';' => found.push((line, c)),
            _ => {}
        }
        i += 1;
    }
    found
}

/// Each function of `code` (before its tests) with its length in lines.
fn function_lengths(code: &str) -> Vec<(String, usize)> {
    let code = match code.find("#[cfg(test)]") {
        Some(i) => &code[..i],
        None => code,
    };
    let structure = structure_of(code);
    let mut lengths = Vec::new();
    for (index, text) in code.lines().enumerate() {
        let words: Vec<&str> = text.split_whitespace().collect();
        let Some(at) = words.iter().position(|w| *w == "fn") else {
            continue;
        };
        let before_ok = words[..at].iter().all(|w| {
            w.starts_with("pub") || matches!(*w, "async" | "const" | "unsafe" | "extern" | "\"C\"")
        });
        if !before_ok || at + 1 >= words.len() {
            continue;
        }
        let name: String = words[at + 1]
            .chars()
            .take_while(|c| c.is_alphanumeric() || *c == '_')
            .collect();
        let start = index + 1;
        let mut depth = 0usize;
        let mut end = None;
        for &(line, c) in structure.iter().filter(|(line, _)| *line >= start) {
            match c {
                ';' if depth == 0 => break, // a declaration without a body
                '{' => depth += 1,
                '}' => {
                    depth = depth.saturating_sub(1);
                    if depth == 0 {
                        end = Some(line);
                        break;
                    }
                }
                _ => {}
            }
        }
        if let Some(end) = end {
            lengths.push((name, end - start + 1));
        }
    }
    lengths
}

#[test]
fn the_length_of_a_function_is_counted_from_its_signature_to_its_closing_brace() {
    let code = "fn short() {\n    let s = \"}{\";\n    let c = '}';\n}\n\npub(crate) fn declared();\n\nasync fn long<'a>(x: &'a str) {\n    // }\n    if x.is_empty() {\n    }\n}\n\nfn pair(axes: &[String; 2]) {\n}\n";
    assert_eq!(
        function_lengths(code),
        vec![
            ("short".to_string(), 4),
            ("long".to_string(), 5),
            ("pair".to_string(), 2)
        ]
    );
}

#[test]
fn no_function_is_longer_than_a_screen_and_a_half_unless_listed() {
    let root = workspace_root();
    let mut long = Vec::new();
    for package in workspace_packages() {
        let mut files = Vec::new();
        collect_rs_files(&package.src_dir, &mut files);
        for file in files {
            let relative = file
                .strip_prefix(&root)
                .unwrap()
                .to_string_lossy()
                .into_owned();
            let text = std::fs::read_to_string(&file).unwrap();
            for (name, lines) in function_lengths(&text) {
                if lines > LONGEST_FUNCTION_LINES {
                    long.push((relative.clone(), name, lines));
                }
            }
        }
    }
    let unlisted: Vec<String> = long
        .iter()
        .filter(|(path, name, _)| {
            !LONG_FUNCTIONS
                .iter()
                .any(|(p, n, _)| p == path && n == name)
        })
        .map(|(path, name, lines)| format!("{path}: {name} ({lines} lines)"))
        .collect();
    assert!(
        unlisted.is_empty(),
        "functions over {LONGEST_FUNCTION_LINES} lines: split them by what they do, or list them in LONG_FUNCTIONS with why they stay whole: {unlisted:#?}"
    );
    let stale: Vec<String> = LONG_FUNCTIONS
        .iter()
        .filter(|(p, n, _)| !long.iter().any(|(path, name, _)| path == p && name == n))
        .map(|(path, name, _)| format!("{path}: {name}"))
        .collect();
    assert!(
        stale.is_empty(),
        "no longer over {LONGEST_FUNCTION_LINES} lines: take them off LONG_FUNCTIONS: {stale:?}"
    );
}

// ---- ARCHITECTURE.md kept true ------------------------------------------------

fn architecture_md() -> String {
    std::fs::read_to_string(workspace_root().join("ARCHITECTURE.md")).unwrap()
}

/// Every file and folder of the checkout, relative to its root, with `/`
/// between the parts (folders end in `/`), outside what builds and tools
/// make (`target/`, the guide's `book/`, the fuzzers' corpora).
fn checkout_paths() -> Vec<String> {
    fn walk(root: &Path, dir: &Path, out: &mut Vec<String>) {
        let Ok(entries) = std::fs::read_dir(dir) else {
            return;
        };
        for entry in entries.flatten() {
            let path = entry.path();
            let name = entry.file_name().to_string_lossy().into_owned();
            if matches!(
                name.as_str(),
                ".git" | "target" | "book" | "corpus" | "artifacts"
            ) {
                continue;
            }
            let relative = path
                .strip_prefix(root)
                .unwrap()
                .to_string_lossy()
                .replace('\\', "/");
            if path.is_dir() {
                out.push(format!("{relative}/"));
                walk(root, &path, out);
            } else {
                out.push(relative);
            }
        }
    }
    let root = workspace_root();
    let mut out = Vec::new();
    walk(&root, &root, &mut out);
    out
}

/// The code spans of a Markdown text that name a file or folder of the
/// checkout: a span with a `/` or a Rust file's name, without spaces,
/// placeholders (`<name>`), globs or URLs. A path may be given from the
/// root (`can/src/log/`) or from a folder a table row names (`log/`,
/// `spec/checks.rs`): it must be the end of some path of the checkout.
fn paths_named(markdown: &str) -> Vec<String> {
    let mut named = Vec::new();
    for (i, span) in markdown.split('`').enumerate() {
        if i % 2 == 0 {
            continue;
        }
        let looks_like_path = span.contains('/') || span.ends_with(".rs");
        let excluded = span.is_empty()
            || span.contains(char::is_whitespace)
            || span.contains(['<', '*', '{', '$', '=', ':'])
            || span.starts_with('-')
            || span.starts_with('/')
            || span.starts_with('.') && !span.starts_with(".config/") && !span.starts_with(".ci/");
        if looks_like_path && !excluded {
            named.push(span.to_string());
        }
    }
    named
}

/// The spans of `paths_named` that no path of the checkout ends with.
fn missing_paths(markdown: &str, checkout: &[String]) -> Vec<String> {
    paths_named(markdown)
        .into_iter()
        .filter(|named| {
            !checkout.iter().any(|path| {
                path == named
                    || path.ends_with(&format!("/{named}"))
                    || (!named.ends_with('/') && path == &format!("{named}/"))
                    || (!named.ends_with('/') && path.ends_with(&format!("/{named}/")))
            })
        })
        .collect()
}

#[test]
fn every_path_architecture_md_names_exists() {
    let missing = missing_paths(&architecture_md(), &checkout_paths());
    assert!(
        missing.is_empty(),
        "ARCHITECTURE.md names paths that do not exist (moved or renamed? keep the map true): {missing:?}"
    );
}

#[test]
fn the_path_check_sees_a_path_that_is_gone() {
    let checkout = vec![
        "rig/".to_string(),
        "rig/src/".to_string(),
        "rig/src/record.rs".to_string(),
        "can/src/log/".to_string(),
    ];
    let page = "its record in `rig.rs` (`SensorRecord`), formats in `drivers/src/log/`, \
                `rig/src/record.rs`, `log/`, `src/record.rs`, `<name>/x.rs`, `acq --help`";
    assert_eq!(
        missing_paths(page, &checkout),
        ["rig.rs", "drivers/src/log/"]
    );
}

/// One recipe of ARCHITECTURE.md's "Where a change goes": its bold label,
/// the commit that last made such a change (`(last: `COMMIT`)` after the
/// label), and its text up to the next label.
struct Recipe {
    label: String,
    last: Option<String>,
    text: String,
}

fn recipes(markdown: &str) -> Vec<Recipe> {
    let Some(section) = markdown.split("## Where a change goes").nth(1) else {
        return Vec::new();
    };
    let section = section.split("\n## ").next().unwrap();
    // Bold text in the section is a recipe's label: "**label**", then its text.
    let parts: Vec<&str> = section.split("**").skip(1).collect();
    parts
        .chunks(2)
        .map(|pair| {
            let text = pair.get(1).copied().unwrap_or("");
            let last = text
                .trim_start()
                .strip_prefix("(last: `")
                .and_then(|rest| rest.split('`').next())
                .map(str::to_string);
            Recipe {
                label: pair[0].to_string(),
                last,
                text: text.to_string(),
            }
        })
        .collect()
}

/// `git ARGS` run in the workspace; fails the test when git is missing.
fn git(args: &[&str]) -> std::process::Output {
    Command::new("git")
        .arg("-C")
        .arg(workspace_root())
        .args(args)
        .output()
        .unwrap_or_else(|e| {
            panic!(
                "git {} did not run ({e}): this check reads the history, it needs git",
                args.join(" ")
            )
        })
}

/// What `git ARGS` prints; fails the test with git's own message when git
/// refuses.
fn git_output(args: &[&str]) -> String {
    let output = git(args);
    assert!(
        output.status.success(),
        "git {} failed: {}",
        args.join(" "),
        String::from_utf8_lossy(&output.stderr)
    );
    String::from_utf8_lossy(&output.stdout).into_owned()
}

/// Whether `name` is a commit of the history, by at least 7 hex digits.
fn is_a_commit(name: &str) -> bool {
    name.len() >= 7
        && name.chars().all(|c| c.is_ascii_hexdigit())
        && git(&[
            "rev-parse",
            "--verify",
            "--quiet",
            &format!("{name}^{{commit}}"),
        ])
        .status
        .success()
}

/// The files `commit` changed, as it named them.
fn files_changed_by(commit: &str) -> Vec<String> {
    git_output(&["show", "--name-only", "--format=", commit, "--"])
        .lines()
        .filter(|line| !line.is_empty())
        .map(str::to_string)
        .collect()
}

/// Every rename since `commit` up to HEAD as (old, new), oldest first. Each
/// commit's renames are found in that commit (a move such as drivers/ into
/// can/ and rig/ renames whole files at once): one diff from `commit` to
/// HEAD loses a file that changed much after its move.
fn renames_since(commit: &str) -> Vec<(String, String)> {
    let range = format!("{commit}..HEAD");
    let log = git_output(&[
        "log",
        "--reverse",
        "-M",
        "-l0",
        "--diff-filter=R",
        "--name-status",
        "--format=",
        &range,
    ]);
    log.lines()
        .filter_map(|line| {
            let mut fields = line.split('\t');
            let status = fields.next()?;
            let (old, new) = (fields.next()?, fields.next()?);
            status
                .starts_with('R')
                .then(|| (old.to_string(), new.to_string()))
        })
        .collect()
}

/// Where `path` is after `renames` (oldest first), taken in turn.
fn path_after(path: &str, renames: &[(String, String)]) -> String {
    renames.iter().fold(path.to_string(), |path, (old, new)| {
        if path == *old {
            new.clone()
        } else {
            path
        }
    })
}

/// A file a recipe is about: Rust under a crate's `src/` (the binary's and
/// the binding's too) or the page's assets. Tests, benches, examples,
/// fixtures, fuzz targets, docs and manifests go with any kind of change.
fn is_source_file(path: &str) -> bool {
    let in_src = path.starts_with("src/") || path.split('/').nth(1) == Some("src");
    (in_src && path.ends_with(".rs")) || path.starts_with("view/assets/")
}

/// Whether `path`'s segments begin with `pattern`'s, where a
/// `<placeholder>` segment stands for any one.
fn starts_with_segments(path: &[&str], pattern: &[&str]) -> bool {
    path.len() >= pattern.len()
        && path.iter().zip(pattern).all(|(segment, wanted)| {
            segment == wanted || (wanted.starts_with('<') && wanted.ends_with('>'))
        })
}

/// Whether a named path (a folder when it ends in `/`) is `file` or holds it.
fn names_file(named: &str, file: &str) -> bool {
    let file: Vec<&str> = file.split('/').collect();
    match named.strip_suffix('/') {
        Some(folder) => {
            let folder: Vec<&str> = folder.split('/').collect();
            file.len() > folder.len() && starts_with_segments(&file, &folder)
        }
        None => {
            let named: Vec<&str> = named.split('/').collect();
            file.len() == named.len() && starts_with_segments(&file, &named)
        }
    }
}

/// The files of `touched` that `recipe` does not name. It names a file by
/// its path, by a folder that holds it (`can/src/log/`), or by a pattern
/// with a placeholder (`twins/src/<name>/`). A path written short, as the
/// page does beside a path it gave in full (`spec/checks.rs` after
/// `study/src/spec/schema.rs`, `plausibility.rs` after
/// `analysis/src/extract/stats.rs`), is read under each folder on the way to
/// the other paths the recipe names.
fn files_a_recipe_leaves_out(recipe: &str, touched: &[String]) -> Vec<String> {
    let mut named = paths_named(recipe);
    // `paths_named` leaves placeholders out; here they are patterns.
    named.extend(
        recipe
            .split('`')
            .skip(1)
            .step_by(2)
            .filter(|span| span.contains('<') && span.contains('/'))
            .filter(|span| !span.contains(char::is_whitespace))
            .map(str::to_string),
    );
    let folders_on_the_way: BTreeSet<&str> = named
        .iter()
        .flat_map(|path| path.match_indices('/').map(|(i, _)| &path[..=i]))
        .collect();
    let mut readings = named.clone();
    for folder in &folders_on_the_way {
        readings.extend(named.iter().map(|path| format!("{folder}{path}")));
    }
    touched
        .iter()
        .filter(|file| !readings.iter().any(|named| names_file(named, file)))
        .cloned()
        .collect()
}

/// Each recipe that names its last change names every source file that
/// change touched (where each is now, after renames and moves; one since
/// deleted is left out), so the next change of that kind finds them all.
#[test]
fn every_recipe_names_the_files_its_last_change_touched() {
    let root = workspace_root();
    let recipes = recipes(&architecture_md());
    let dated: Vec<(&Recipe, &str)> = recipes
        .iter()
        .filter_map(|recipe| Some((recipe, recipe.last.as_deref()?)))
        .collect();
    assert!(
        !dated.is_empty(),
        "no recipe under \"Where a change goes\" in ARCHITECTURE.md gives its last change as **label** (last: `COMMIT`)"
    );
    let mut problems = Vec::new();
    for (recipe, commit) in dated {
        assert!(
            is_a_commit(commit),
            "{}: its last change `{commit}` is no commit of this history (a full clone has them all; give 7 or more hex digits of one)",
            recipe.label
        );
        let renames = renames_since(commit);
        let touched: Vec<String> = files_changed_by(commit)
            .iter()
            .map(|path| path_after(path, &renames))
            .filter(|path| is_source_file(path) && root.join(path).is_file())
            .collect();
        let left_out = files_a_recipe_leaves_out(&recipe.text, &touched);
        if !left_out.is_empty() {
            problems.push(format!(
                "{} (last: {commit}) does not name {left_out:?}",
                recipe.label
            ));
        }
    }
    assert!(
        problems.is_empty(),
        "ARCHITECTURE.md's recipes leave out files their last change touched: name each (or its folder) where it belongs to that kind of change, or give a commit that made only that change:\n{}",
        problems.join("\n")
    );
}

#[test]
fn the_recipe_check_sees_a_file_left_out() {
    let page = "## Where a change goes\n\
                - **A spec key** (last: `843bc19`): `study/src/spec/schema.rs`, its check in \
                `spec/checks.rs` (or `assemble.rs`). **A twin**: `twins/src/<name>/`, then \
                `workflows/src/calibrate/`.\n\n## Invariants\n- **Not a recipe**.";
    let recipes = recipes(page);
    assert_eq!(recipes.len(), 2);
    assert_eq!(recipes[0].label, "A spec key");
    assert_eq!(recipes[0].last.as_deref(), Some("843bc19"));
    assert_eq!(recipes[1].last, None);
    let files = |paths: &[&str]| paths.iter().map(|p| p.to_string()).collect::<Vec<_>>();
    let spec_key = &recipes[0].text;
    assert_eq!(
        files_a_recipe_leaves_out(
            spec_key,
            &files(&[
                "study/src/spec/schema.rs",
                "study/src/spec/checks.rs",
                "study/src/spec/assemble.rs",
                "study/src/spec/observations.rs",
            ])
        ),
        ["study/src/spec/observations.rs"]
    );
    // A short path is read beside the recipe's full ones, not anywhere.
    let elsewhere = files(&["workflows/src/spec/checks.rs", "analysis/src/assemble.rs"]);
    assert_eq!(files_a_recipe_leaves_out(spec_key, &elsewhere), elsewhere);
    // A placeholder stands for one folder, and a folder holds its files only.
    assert_eq!(
        files_a_recipe_leaves_out(
            &recipes[1].text,
            &files(&[
                "workflows/src/calibrate/models.rs",
                "twins/src/tensile/gtn.rs",
                "twins/src/lib.rs",
            ])
        ),
        ["twins/src/lib.rs"]
    );
    // A file is followed through every rename since, and only source files count.
    let renames = [
        ("drivers/src/log/mod.rs", "can/src/log/mod.rs"),
        ("can/src/log/mod.rs", "can/src/log/formats.rs"),
    ]
    .map(|(old, new)| (old.to_string(), new.to_string()));
    assert_eq!(
        path_after("drivers/src/log/mod.rs", &renames),
        "can/src/log/formats.rs"
    );
    assert!(is_source_file("src/cli/calibrate.rs") && is_source_file("view/assets/app.js"));
    assert!(!is_source_file("can/tests/it/mf4.rs"));
    assert!(!is_source_file("fuzz/fuzz_targets/mf4_log.rs"));
}

/// The crates ARCHITECTURE.md calls leaves: the code spans on its line
/// that starts `**Leaves**`.
fn leaves_named(markdown: &str) -> Vec<String> {
    let Some(start) = markdown.find("**Leaves**") else {
        return Vec::new();
    };
    let paragraph = markdown[start..].split("\n\n").next().unwrap();
    paragraph
        .split('`')
        .skip(1)
        .step_by(2)
        .map(str::to_string)
        .collect()
}

/// Where the leaves ARCHITECTURE.md names and the crates with no workspace
/// dependency part ways, one line each.
fn leaf_disagreements(named: &[String], packages: &[(String, BTreeSet<String>)]) -> Vec<String> {
    let mut wrong = Vec::new();
    for (name, workspace_deps) in packages {
        let is_named = named.contains(name);
        if is_named && !workspace_deps.is_empty() {
            wrong.push(format!(
                "{name} is called a leaf but depends on {workspace_deps:?}"
            ));
        }
        if !is_named && workspace_deps.is_empty() && name != "acq" {
            wrong.push(format!(
                "{name} has no workspace dependency but is not among the leaves"
            ));
        }
    }
    for name in named {
        if !packages.iter().any(|(package, _)| package == name) {
            wrong.push(format!(
                "{name} is called a leaf but is no crate of the workspace"
            ));
        }
    }
    wrong
}

#[test]
fn the_leaves_architecture_md_names_are_the_crates_with_no_workspace_dependency() {
    let named = leaves_named(&architecture_md());
    assert!(
        !named.is_empty(),
        "ARCHITECTURE.md has no line starting **Leaves**"
    );
    let packages: Vec<(String, BTreeSet<String>)> = workspace_packages()
        .into_iter()
        .map(|p| (p.name, p.workspace_deps))
        .collect();
    let wrong = leaf_disagreements(&named, &packages);
    assert!(
        wrong.is_empty(),
        "ARCHITECTURE.md's leaves and the workspace part ways: {wrong:#?}"
    );
}

#[test]
fn the_leaf_check_sees_a_leaf_that_is_not_one() {
    let page = "**Leaves**, crates with no workspace dependency: `acq-a`,\n`acq-gone`.\n\nNext.";
    let named = leaves_named(page);
    assert_eq!(named, ["acq-a", "acq-gone"]);
    let packages = vec![
        ("acq-a".to_string(), BTreeSet::from(["acq-b".to_string()])),
        ("acq-b".to_string(), BTreeSet::new()),
    ];
    assert_eq!(leaf_disagreements(&named, &packages).len(), 3);
}

/// A source file's lines before its unit tests (`#[cfg(test)]` at the
/// start of a line).
fn lines_before_tests(code: &str) -> usize {
    code.lines()
        .take_while(|line| !line.starts_with("#[cfg(test)]"))
        .count()
}

const LONGEST_FILE_LINES: usize = 1000;

#[test]
fn no_source_file_passes_a_thousand_lines_unless_architecture_md_says_why() {
    assert_eq!(lines_before_tests("a\nb\n#[cfg(test)]\nmod tests {}\n"), 2);
    let root = workspace_root();
    let page = architecture_md();
    let listed = page
        .split("## Long files")
        .nth(1)
        .and_then(|rest| rest.split("\n## ").next())
        .unwrap_or("");
    let mut unlisted = Vec::new();
    for package in workspace_packages() {
        let mut files = Vec::new();
        collect_rs_files(&package.src_dir, &mut files);
        for file in files {
            let lines = lines_before_tests(&std::fs::read_to_string(&file).unwrap());
            let relative = file
                .strip_prefix(&root)
                .unwrap()
                .to_string_lossy()
                .into_owned();
            if lines > LONGEST_FILE_LINES && !listed.contains(&format!("`{relative}`")) {
                unlisted.push(format!("{relative} ({lines} lines)"));
            }
        }
    }
    assert!(
        unlisted.is_empty(),
        "source files over {LONGEST_FILE_LINES} lines before their tests: split them by what they hold, or list them under \"Long files\" in ARCHITECTURE.md with why they stay whole: {unlisted:#?}"
    );
}

/// Each package's versions in a Cargo.lock, by name.
fn locked_versions(lock: &str) -> BTreeMap<String, BTreeSet<String>> {
    let lock: toml::Table = lock.parse().expect("a Cargo.lock is TOML");
    let mut versions = BTreeMap::<String, BTreeSet<String>>::new();
    for package in lock
        .get("package")
        .and_then(toml::Value::as_array)
        .into_iter()
        .flatten()
    {
        let field = |key: &str| package.get(key).and_then(toml::Value::as_str);
        if let (Some(name), Some(version)) = (field("name"), field("version")) {
            versions
                .entry(name.to_string())
                .or_default()
                .insert(version.to_string());
        }
    }
    versions
}

/// The packages the fuzz build locks at a version the workspace does not.
fn versions_apart(workspace_lock: &str, fuzz_lock: &str) -> Vec<String> {
    let workspace = locked_versions(workspace_lock);
    locked_versions(fuzz_lock)
        .into_iter()
        .filter_map(|(name, versions)| {
            let pinned = workspace.get(&name)?;
            let apart: Vec<_> = versions.difference(pinned).cloned().collect();
            (!apart.is_empty()).then(|| {
                format!(
                    "{name} {} (the workspace has {})",
                    apart.join(", "),
                    pinned.iter().cloned().collect::<Vec<_>>().join(", ")
                )
            })
        })
        .collect()
}

/// The fuzz smoke reuses the third-party crates of the workspace's release
/// build (scripts/fuzz-smoke); a package fuzz/Cargo.lock holds at another
/// version is built again, and so is every crate above it.
#[test]
fn the_fuzz_build_locks_the_workspace_s_versions() {
    let read = |path: &str| std::fs::read_to_string(workspace_root().join(path)).unwrap();
    let apart = versions_apart(&read("Cargo.lock"), &read("fuzz/Cargo.lock"));
    assert!(
        apart.is_empty(),
        "fuzz/Cargo.lock holds versions the workspace's Cargo.lock does not: {}; copy Cargo.lock over fuzz/Cargo.lock and run `cargo metadata` in fuzz/",
        apart.join("; ")
    );
}

#[test]
fn the_version_check_sees_a_version_apart() {
    let lock = |version: &str| {
        format!("version = 4\n\n[[package]]\nname = \"bytes\"\nversion = \"{version}\"\n")
    };
    assert!(versions_apart(&lock("1.12.1"), &lock("1.12.1")).is_empty());
    assert_eq!(
        versions_apart(&lock("1.12.1"), &lock("1.12.2")),
        ["bytes 1.12.2 (the workspace has 1.12.1)"]
    );
}
