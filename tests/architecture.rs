//! The app's files import one way: no file of `crates/volasso-app/src` reaches, through its
//! `crate::` and `super::` imports, a file that reaches it back (the crate root, which declares
//! them all and holds the shared state, aside). Cargo enforces the boundaries between crates;
//! this test the one inside the app, so that a feature's part of the model never needs the
//! view's or another feature's internals that need it in turn. And the app's Slint-bound code
//! stays glue within its budget.

use std::collections::{BTreeMap, BTreeSet};
use std::path::{Path, PathBuf};

/// The app crate's source folder.
fn app_source() -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("crates/volasso-app/src")
}

fn rust_files(folder: &Path, found: &mut Vec<PathBuf>) {
    for entry in std::fs::read_dir(folder).unwrap() {
        let path = entry.unwrap().path();
        if path.is_dir() {
            rust_files(&path, found);
        } else if path.extension().is_some_and(|extension| extension == "rs") {
            found.push(path);
        }
    }
}

/// A file's module path (`lasso::drawing`); `None` for the crate root and test files.
fn module_of(root: &Path, file: &Path) -> Option<String> {
    let relative = file.strip_prefix(root).ok()?.with_extension("");
    let mut parts: Vec<String> = relative.iter().map(|part| part.to_string_lossy().into_owned()).collect();
    if parts.last().is_some_and(|last| last == "mod") {
        parts.pop();
    }
    let last = parts.last()?;
    if parts == ["lib"] || last == "tests" || last.ends_with("_tests") {
        return None;
    }
    Some(parts.join("::"))
}

/// The words of `text` after `prefix` joined by `::` (`crate::a::b::C` gives `a::b::C`).
fn paths_after<'a>(text: &'a str, prefix: &str) -> Vec<&'a str> {
    let mut found = Vec::new();
    let mut rest = text;
    while let Some(at) = rest.find(prefix) {
        let before = rest[..at].chars().last();
        rest = &rest[at + prefix.len()..];
        if before.is_some_and(|c| c.is_alphanumeric() || c == '_' || c == ':') {
            continue;
        }
        let end = rest.find(|c: char| !(c.is_alphanumeric() || c == '_' || c == ':')).unwrap_or(rest.len());
        found.push(rest[..end].trim_end_matches(':'));
    }
    found
}

/// The module among `modules` that `path` names or lies in (the longest match).
fn resolve(modules: &BTreeSet<String>, path: &str) -> Option<String> {
    let parts: Vec<&str> = path.split("::").collect();
    (1..=parts.len()).rev().map(|n| parts[..n].join("::")).find(|candidate| modules.contains(candidate))
}

/// Each module's imports of the others: `crate::` and `super::` paths and `{...}` groups.
fn import_graph() -> BTreeMap<String, BTreeSet<String>> {
    let root = app_source();
    let mut files = Vec::new();
    rust_files(&root, &mut files);
    let modules: BTreeMap<String, PathBuf> =
        files.iter().filter_map(|file| module_of(&root, file).map(|module| (module, file.clone()))).collect();
    let names: BTreeSet<String> = modules.keys().cloned().collect();
    let mut graph = BTreeMap::new();
    for (module, file) in &modules {
        let text = std::fs::read_to_string(file).unwrap();
        // The code, without its tests and comments.
        let code = text.split("\n#[cfg(test)]\n").next().unwrap_or_default();
        let code: String =
            code.lines().filter(|line| !line.trim_start().starts_with("//")).collect::<Vec<_>>().join("\n");
        // What `super` names: the module's parent (for `lasso/drawing.rs` and `lasso/mod.rs`
        // alike, `lasso` and the crate root).
        let parent = module.rsplit_once("::").map_or("", |(parent, _)| parent);
        let within = |path: &str| if parent.is_empty() { path.to_string() } else { format!("{parent}::{path}") };
        let mut imports = BTreeSet::new();
        for path in paths_after(&code, "crate::") {
            imports.extend(resolve(&names, path));
        }
        for path in paths_after(&code, "super::") {
            imports.extend(resolve(&names, &within(path)));
        }
        for (opening, place) in [("super::{", true), ("crate::{", false)] {
            for group in code.split(opening).skip(1) {
                let inside = group.split('}').next().unwrap_or_default();
                for name in inside.split([',', ' ', '\n']).map(|word| word.split("::").next().unwrap_or_default()) {
                    if !name.is_empty() {
                        imports.extend(resolve(&names, &if place { within(name) } else { name.to_string() }));
                    }
                }
            }
        }
        imports.remove(module);
        graph.insert(module.clone(), imports);
    }
    graph
}

/// A cycle through `start`, if there is one: the modules along it.
fn cycle_through(graph: &BTreeMap<String, BTreeSet<String>>, start: &str) -> Option<Vec<String>> {
    let mut stack = vec![(start.to_string(), vec![start.to_string()])];
    let mut seen = BTreeSet::new();
    while let Some((module, path)) = stack.pop() {
        for next in graph.get(&module).into_iter().flatten() {
            if next == start {
                return Some([path.clone(), vec![start.to_string()]].concat());
            }
            if seen.insert(next.clone()) {
                stack.push((next.clone(), [path.clone(), vec![next.clone()]].concat()));
            }
        }
    }
    None
}

#[test]
fn no_file_of_the_app_imports_a_file_that_imports_it_back() {
    let graph = import_graph();
    assert!(graph.len() > 30, "the app's files were not found: {graph:?}");
    // The graph is real: the callbacks reach the model and the view, and each feature's part
    // of the model reaches the model.
    assert!(graph["callbacks"].contains("model") && graph["callbacks"].contains("view"), "{:?}", graph["callbacks"]);
    assert!(graph["chooser::loading"].contains("model"), "{:?}", graph["chooser::loading"]);
    let cycles: Vec<Vec<String>> = graph.keys().filter_map(|module| cycle_through(&graph, module)).collect();
    assert!(cycles.is_empty(), "import cycles: {cycles:?}");
}

#[test]
fn the_cycle_finder_finds_a_cycle() {
    let graph: BTreeMap<String, BTreeSet<String>> = [
        ("a".to_string(), BTreeSet::from(["b".to_string()])),
        ("b".to_string(), BTreeSet::from(["c".to_string()])),
        ("c".to_string(), BTreeSet::from(["a".to_string()])),
        ("d".to_string(), BTreeSet::from(["a".to_string()])),
    ]
    .into();
    assert_eq!(cycle_through(&graph, "a"), Some(vec!["a".into(), "b".into(), "c".into(), "a".into()]));
    assert_eq!(cycle_through(&graph, "d"), None);
}

/// The crates depend on each other one way, so cargo refuses an import that runs back: the
/// pipeline knows no UI, display or touch code; the app knows no DRM or evdev code (the kiosk
/// platform's) and no command line; the appliance's policies know neither the app nor the kiosk;
/// the kiosk's platform knows nothing of the replay harness that drives it.
#[test]
fn the_crates_depend_one_way() {
    // The names a crate's `[dependencies]` tables list (the target-specific ones too).
    let dependencies = |crate_folder: &str| -> BTreeSet<String> {
        let manifest = Path::new(env!("CARGO_MANIFEST_DIR")).join(crate_folder).join("Cargo.toml");
        let text = std::fs::read_to_string(&manifest).unwrap();
        let mut in_dependencies = false;
        let mut names = BTreeSet::new();
        for line in text.lines().map(str::trim) {
            if line.starts_with('[') {
                in_dependencies = line.ends_with("dependencies]") && !line.contains("dev-dependencies");
            } else if in_dependencies && let Some((name, _)) = line.split_once('=') {
                names.insert(name.trim().to_string());
            }
        }
        names
    };
    let forbidden: [(&str, &[&str]); 5] = [
        ("crates/volasso-core", &["slint", "volasso-ui", "volasso-app", "volasso-kiosk", "evdev", "drm", "winit"]),
        ("crates/volasso-app", &["volasso-kiosk", "evdev", "drm", "winit", "clap"]),
        ("crates/volasso-appliance", &["slint", "volasso-app", "volasso-kiosk", "volasso-ui"]),
        ("crates/volasso-kiosk", &["clap", "volasso-dicom", "volasso-replay"]),
        ("crates/volasso-replay", &["clap", "volasso-dicom", "evdev", "drm"]),
    ];
    for (crate_folder, names) in forbidden {
        let listed = dependencies(crate_folder);
        assert!(listed.contains("log"), "{crate_folder}: its dependencies were read: {listed:?}");
        for name in names {
            assert!(!listed.contains(*name), "{crate_folder} depends on {name}");
        }
    }
}

/// Whether `text` is Slint-bound code: it names Slint, the generated UI module or Slint's
/// testing backend in an import or a path.
fn slint_bound(text: &str) -> bool {
    text.lines().filter(|line| !line.trim_start().starts_with("//")).any(|line| {
        let line = line.trim_start();
        line.contains("slint::")
            || line.starts_with("use crate::ui")
            || line.starts_with("use super::ui")
            || line.starts_with("use i_slint")
            || (line.starts_with("use crate::{") && line.contains(" ui"))
    })
}

/// The app's behaviour lives in its Slint-free model (`model/`, each feature's logic and
/// `app.rs`), tested without a window; the Slint-bound code (the callbacks' table, the view,
/// the window's set-up) stays glue. A feature whose logic lands in a Slint-bound file instead
/// has no test without a window: this budget catches it.
#[test]
fn the_slint_bound_code_of_the_app_is_glue_of_at_most_1000_lines() {
    let mut files = Vec::new();
    rust_files(&app_source(), &mut files);
    let bound: Vec<(usize, PathBuf)> = files
        .into_iter()
        .filter_map(|file| {
            let text = std::fs::read_to_string(&file).unwrap();
            slint_bound(&text).then(|| (text.lines().count(), file))
        })
        .collect();
    let model = std::fs::read_to_string(app_source().join("model/mod.rs")).unwrap();
    assert!(!slint_bound(&model), "the model is Slint-free");
    assert!(bound.iter().any(|(_, file)| file.ends_with("callbacks.rs")), "the finder finds the callbacks: {bound:?}");
    let lines: usize = bound.iter().map(|(lines, _)| lines).sum();
    assert!(lines <= 1000, "{lines} lines of Slint-bound code in the app: {bound:?}");
}
