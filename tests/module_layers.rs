//! The house's layers: no module of `src/` imports one above it, and no two modules of one
//! room import each other, directly or in a circle.
//!
//! The rooms, top to bottom, are [`LAYERS`]: a module may use the modules below its own and
//! none above. Inside a room (`shading/`, `render/` …) the files form a graph of their own,
//! which must have no circle: a lobe imports the BSDF interface, the enum of lobes imports the
//! lobes, and the interface imports neither. Edges between a module and its own parent
//! (`mod.rs` declaring and re-exporting its children; a child using an item its parent
//! defines) are the module tree itself and are not counted. A name used through a parent's
//! re-export (`use super::Bsdf`, `crate::shading::Bsdf`) counts as a use of the file that
//! defines it.
//!
//! The scan reads `use` declarations and inline `crate::`/`super::`/`self::` paths, after
//! dropping comments and `#[cfg(test)]` modules (a test may import what it tests from
//! anywhere). It is a text scan, not a compiler pass, and knows it: the negative controls at
//! the end feed it small trees with a known circle and a known upward import.

use std::collections::{BTreeMap, BTreeSet};
use std::path::Path;

/// The top-level modules of `src/`, top to bottom. A new module is placed here, or the test
/// fails naming it.
const LAYERS: &[&str] = &[
    "report",
    "job",
    "cli",
    "denoise",
    "convergence",
    "plot",
    "render",
    "integrators",
    "record",
    "experiments",
    "shading",
    "accel",
    "texture",
    "scene",
    "sampling",
    "embree",
    "ray",
    "math",
    "lanes",
];

/// A module path, e.g. `["shading", "bsdf"]`.
type Module = Vec<String>;

/// The library's source files as module path → source text (`lib.rs`, `main.rs` and the
/// binaries under `src/bin` are not modules of the library's layers).
fn read_tree(src: &Path) -> BTreeMap<Module, String> {
    let mut tree = BTreeMap::new();
    let mut stack = vec![src.to_path_buf()];
    while let Some(dir) = stack.pop() {
        for entry in std::fs::read_dir(&dir).expect("src/ is readable") {
            let path = entry.expect("a directory entry").path();
            if path.is_dir() {
                if path.file_name().is_some_and(|n| n != "bin") {
                    stack.push(path);
                }
                continue;
            }
            if path.extension().is_none_or(|e| e != "rs") {
                continue;
            }
            let rel = path.strip_prefix(src).unwrap();
            let mut module: Module = rel
                .with_extension("")
                .iter()
                .map(|s| s.to_string_lossy().into_owned())
                .collect();
            if module.last().is_some_and(|m| m == "mod") {
                module.pop();
            }
            if module == ["lib"] || module == ["main"] {
                continue;
            }
            tree.insert(module, std::fs::read_to_string(&path).unwrap());
        }
    }
    tree
}

/// The source without comments and without its `#[cfg(test)] mod …` modules.
fn code_of(source: &str) -> String {
    let mut out = String::new();
    let mut lines = source.lines().peekable();
    while let Some(line) = lines.next() {
        let trimmed = line.trim_start();
        if trimmed.starts_with("#[cfg(test)]") {
            // Skip the attribute's item if it is a module: up to its closing brace.
            let next = lines.peek().map(|l| l.trim_start()).unwrap_or("");
            if next.starts_with("mod ") || next.starts_with("pub mod ") {
                let mut depth = 0i32;
                let mut opened = false;
                for l in lines.by_ref() {
                    for c in l.chars() {
                        match c {
                            '{' => {
                                depth += 1;
                                opened = true;
                            }
                            '}' => depth -= 1,
                            _ => {}
                        }
                    }
                    if opened && depth <= 0 || !opened && l.trim_end().ends_with(';') {
                        break;
                    }
                }
            }
            continue;
        }
        let code = match line.find("//") {
            Some(i) => &line[..i],
            None => line,
        };
        out.push_str(code);
        out.push('\n');
    }
    out
}

/// Every path a module's code names: each `use` declaration expanded (`a::{b, c::d}` gives
/// `a::b` and `a::c::d`), and each inline path that starts at `crate`, `super` or `self`.
fn paths_of(code: &str) -> Vec<Vec<String>> {
    let mut paths = Vec::new();
    // Inline paths (a `use` of `crate::x::{…}` also yields `crate::x`, harmlessly).
    let bytes = code.as_bytes();
    for start in ["crate::", "super::", "self::"] {
        let mut from = 0;
        while let Some(i) = code[from..].find(start) {
            let at = from + i;
            from = at + start.len();
            if at > 0 && (bytes[at - 1].is_ascii_alphanumeric() || bytes[at - 1] == b'_') {
                continue;
            }
            let mut segments = Vec::new();
            let mut rest = &code[at..];
            loop {
                let len = rest
                    .find(|c: char| !(c.is_ascii_alphanumeric() || c == '_'))
                    .unwrap_or(rest.len());
                if len == 0 {
                    break;
                }
                segments.push(rest[..len].to_string());
                rest = &rest[len..];
                match rest.strip_prefix("::") {
                    Some(r) => rest = r,
                    None => break,
                }
            }
            paths.push(segments);
        }
    }
    // `use` declarations (at the start of a line), with groups.
    let mut lines = code.lines();
    while let Some(line) = lines.next() {
        let line = line.trim_start();
        let line = line
            .strip_prefix("pub(crate) ")
            .or_else(|| line.strip_prefix("pub(super) "))
            .or_else(|| line.strip_prefix("pub "))
            .unwrap_or(line);
        let Some(rest) = line.strip_prefix("use ") else {
            continue;
        };
        let mut declaration = rest.to_string();
        while !declaration.contains(';') {
            match lines.next() {
                Some(next) => declaration.push_str(next),
                None => break,
            }
        }
        let tree: String = declaration
            .split(';')
            .next()
            .unwrap_or("")
            .chars()
            .filter(|c| !c.is_whitespace())
            .collect();
        expand_use(&tree, &mut Vec::new(), &mut paths);
    }
    paths
}

/// Expands one use tree (`a::{b,c::{d,e}}`) under `prefix` into full paths.
fn expand_use(tree: &str, prefix: &mut Vec<String>, out: &mut Vec<Vec<String>>) {
    let Some(open) = tree.find('{') else {
        let mut path = prefix.clone();
        let name = tree.split(" as ").next().unwrap_or(tree);
        let name = name.split("as").next().unwrap_or(name);
        path.extend(
            name.split("::")
                .filter(|s| !s.is_empty() && *s != "*")
                .map(String::from),
        );
        out.push(path);
        return;
    };
    let head: Vec<String> = tree[..open]
        .split("::")
        .filter(|s| !s.is_empty())
        .map(String::from)
        .collect();
    let close = tree.rfind('}').filter(|&c| c > open).unwrap_or(tree.len());
    let inner = &tree[open + 1..close];
    let n = prefix.len();
    prefix.extend(head);
    // Split the group on top-level commas.
    let mut depth = 0;
    let mut start = 0;
    for (i, c) in inner.char_indices() {
        match c {
            '{' => depth += 1,
            '}' => depth -= 1,
            ',' if depth == 0 => {
                if i > start {
                    expand_use(&inner[start..i], prefix, out);
                }
                start = i + 1;
            }
            _ => {}
        }
    }
    if inner.len() > start {
        expand_use(&inner[start..], prefix, out);
    }
    prefix.truncate(n);
}

/// The modules of a tree, and the names each re-exports (`pub use child::Name` → the
/// absolute path of that name), to follow a use through re-exports to its file.
struct Index<'a> {
    tree: &'a BTreeMap<Module, String>,
    reexports: BTreeMap<Module, BTreeMap<String, Vec<String>>>,
}

impl<'a> Index<'a> {
    fn new(tree: &'a BTreeMap<Module, String>) -> Index<'a> {
        let mut reexports = BTreeMap::new();
        for (module, source) in tree {
            let code = code_of(source);
            let is_dir = has_children(tree, module);
            let mut names = BTreeMap::new();
            for line in code.split(';') {
                let line = line.trim();
                let Some(rest) = line
                    .strip_prefix("pub use ")
                    .or_else(|| line.strip_prefix("pub(crate) use "))
                else {
                    continue;
                };
                let tree: String = rest.chars().filter(|c| !c.is_whitespace()).collect();
                let mut paths = Vec::new();
                expand_use(&tree, &mut Vec::new(), &mut paths);
                for path in paths {
                    if let Some(name) = path.last() {
                        names.insert(name.clone(), absolute(module, is_dir, &path));
                    }
                }
            }
            reexports.insert(module.clone(), names);
        }
        Index { tree, reexports }
    }

    /// The module whose file defines what `path` (absolute, from the crate root) names.
    fn resolve(&self, path: &[String]) -> Option<Module> {
        let mut path = path.to_vec();
        for _ in 0..8 {
            // The longest prefix that is a module.
            let k = (1..=path.len())
                .rev()
                .find(|&k| self.tree.contains_key(&path[..k]))?;
            let module = path[..k].to_vec();
            let Some(name) = path.get(k) else {
                return Some(module);
            };
            match self.reexports.get(&module).and_then(|r| r.get(name)) {
                Some(target) if target.as_slice() != path.as_slice() => {
                    let mut next = target.clone();
                    next.extend_from_slice(&path[k + 1..]);
                    path = next;
                }
                _ => return Some(module),
            }
        }
        None
    }
}

/// Whether `module` has child modules: then a relative path in it (`pub use bsdf::Bsdf`)
/// may name one of them.
fn has_children(tree: &BTreeMap<Module, String>, module: &Module) -> bool {
    tree.keys()
        .any(|m| m.len() > module.len() && m.starts_with(module))
}

/// `path` as written in `module` made absolute; `is_dir`: the module has children, which a
/// relative path may name (otherwise a relative path names an external crate).
fn absolute(module: &Module, is_dir: bool, path: &[String]) -> Vec<String> {
    let mut out: Vec<String>;
    let mut rest = path;
    match path.first().map(String::as_str) {
        Some("crate") => {
            out = Vec::new();
            rest = &path[1..];
        }
        Some("super") | Some("self") => {
            // A module's `self` is itself; `super` its parent.
            out = module.clone();
            while let Some(first) = rest.first() {
                match first.as_str() {
                    "super" => {
                        out.pop();
                    }
                    "self" => {}
                    _ => break,
                }
                rest = &rest[1..];
            }
        }
        // A path into a child module declared here (`pub use bsdf::Bsdf` in `mod.rs`), or
        // an external crate.
        Some(_) => {
            out = if is_dir {
                module.clone()
            } else {
                vec!["<extern>".into()]
            };
        }
        None => return Vec::new(),
    }
    out.extend(rest.iter().cloned());
    out
}

/// One import: which file uses which, and the path it wrote.
#[derive(Debug)]
struct Edge {
    from: Module,
    to: Module,
    path: String,
}

fn edges(tree: &BTreeMap<Module, String>) -> Vec<Edge> {
    let index = Index::new(tree);
    let mut out = Vec::new();
    for (module, source) in tree {
        let is_dir = has_children(tree, module);
        for path in paths_of(&code_of(source)) {
            let abs = absolute(module, is_dir, &path);
            if abs.first().is_some_and(|f| f == "<extern>") {
                continue;
            }
            let Some(to) = index.resolve(&abs) else {
                continue;
            };
            // The module tree itself: a module and its ancestors or descendants.
            if to.starts_with(module) || module.starts_with(&to) {
                continue;
            }
            out.push(Edge {
                from: module.clone(),
                to,
                path: path.join("::"),
            });
        }
    }
    out
}

/// What is wrong with a tree's imports, one line each: a top-level module missing from
/// `layers`, an import of a module above, and each circle inside one room.
fn violations(tree: &BTreeMap<Module, String>, layers: &[&str]) -> Vec<String> {
    let rank = |m: &Module| layers.iter().position(|l| *l == m[0]);
    let mut found = BTreeSet::new();
    for module in tree.keys() {
        if rank(module).is_none() {
            found.insert(format!(
                "{}: a top-level module not placed in LAYERS",
                module[0]
            ));
        }
    }
    let edges = edges(tree);
    let mut graph: BTreeMap<Module, BTreeSet<Module>> = BTreeMap::new();
    for e in &edges {
        match (rank(&e.from), rank(&e.to)) {
            (Some(a), Some(b)) if e.from[0] != e.to[0] && a > b => {
                found.insert(format!(
                    "{} imports {} (`{}`), a layer above it",
                    e.from.join("::"),
                    e.to.join("::"),
                    e.path
                ));
            }
            _ if e.from[0] == e.to[0] => {
                graph
                    .entry(e.from.clone())
                    .or_default()
                    .insert(e.to.clone());
            }
            _ => {}
        }
    }
    for cycle in circles(&graph) {
        let names: Vec<String> = cycle.iter().map(|m| m.join("::")).collect();
        found.insert(format!("a circle: {}", names.join(" ↔ ")));
    }
    found.into_iter().collect()
}

/// The strongly connected components of more than one module (Tarjan's algorithm).
fn circles(graph: &BTreeMap<Module, BTreeSet<Module>>) -> Vec<Vec<Module>> {
    struct State<'g> {
        graph: &'g BTreeMap<Module, BTreeSet<Module>>,
        index: BTreeMap<&'g Module, usize>,
        low: BTreeMap<&'g Module, usize>,
        stack: Vec<&'g Module>,
        on_stack: BTreeSet<&'g Module>,
        out: Vec<Vec<Module>>,
    }
    fn visit<'g>(s: &mut State<'g>, v: &'g Module) {
        let i = s.index.len();
        s.index.insert(v, i);
        s.low.insert(v, i);
        s.stack.push(v);
        s.on_stack.insert(v);
        if let Some(next) = s.graph.get(v) {
            for w in next {
                let w = s.graph.get_key_value(w).map(|(k, _)| k).unwrap_or(w);
                if !s.index.contains_key(w) {
                    visit(s, w);
                    let lw = s.low[w];
                    let lv = s.low.get_mut(v).unwrap();
                    *lv = (*lv).min(lw);
                } else if s.on_stack.contains(w) {
                    let iw = s.index[w];
                    let lv = s.low.get_mut(v).unwrap();
                    *lv = (*lv).min(iw);
                }
            }
        }
        if s.low[v] == s.index[v] {
            let mut component = Vec::new();
            while let Some(w) = s.stack.pop() {
                s.on_stack.remove(w);
                component.push(w.clone());
                if w == v {
                    break;
                }
            }
            if component.len() > 1 {
                component.sort();
                s.out.push(component);
            }
        }
    }
    let mut s = State {
        graph,
        index: BTreeMap::new(),
        low: BTreeMap::new(),
        stack: Vec::new(),
        on_stack: BTreeSet::new(),
        out: Vec::new(),
    };
    for v in graph.keys() {
        if !s.index.contains_key(v) {
            visit(&mut s, v);
        }
    }
    s.out
}

#[test]
fn no_module_imports_one_above_it_and_no_room_has_a_circle() {
    let tree = read_tree(&Path::new(env!("CARGO_MANIFEST_DIR")).join("src"));
    assert!(tree.len() > 50, "src/ was not read: {} modules", tree.len());
    let found = violations(&tree, LAYERS);
    assert!(
        found.is_empty(),
        "the house's layers are broken:\n{}",
        found.join("\n")
    );
}

/// A small tree written in the test, module path → source.
fn synthetic(files: &[(&str, &str)]) -> BTreeMap<Module, String> {
    files
        .iter()
        .map(|(m, s)| (m.split("::").map(String::from).collect(), s.to_string()))
        .collect()
}

#[test]
fn an_import_of_a_layer_above_is_found() {
    let tree = synthetic(&[
        ("render", "pub mod film;\npub fn render() {}"),
        ("render::film", "pub struct Film;"),
        (
            "integrators",
            "use crate::render::film::Film; // the back-edge\npub fn li() {}",
        ),
    ]);
    let found = violations(&tree, &["render", "integrators"]);
    assert_eq!(found.len(), 1, "{found:?}");
    assert!(
        found[0].starts_with("integrators imports render::film"),
        "{found:?}"
    );
    // Control: the same tree with the layers the other way round is clean.
    assert!(violations(&tree, &["integrators", "render"]).is_empty());
}

#[test]
fn a_circle_through_a_parents_reexport_is_found() {
    // The interface beside the enum: a lobe imports `super::Bsdf`, which `mod.rs` re-exports
    // from the file that imports the lobe.
    let tree = synthetic(&[
        (
            "shading",
            "pub mod bsdf;\npub mod lobe;\npub use bsdf::{Bsdf, BsdfFlags};",
        ),
        (
            "shading::bsdf",
            "use super::lobe::Lobe;\npub struct BsdfFlags;\npub enum Bsdf { L(Lobe) }",
        ),
        (
            "shading::lobe",
            "use super::{BsdfFlags};\npub struct Lobe;\n#[cfg(test)]\nmod tests {\n    use crate::render::x;\n}\n",
        ),
    ]);
    let found = violations(&tree, &["shading"]);
    assert_eq!(
        found,
        vec!["a circle: shading::bsdf ↔ shading::lobe".to_string()],
        "the test module's import of `render` is not counted, and the circle is"
    );
    // Control: the flags moved to a file of their own, the circle is gone.
    let tree = synthetic(&[
        (
            "shading",
            "pub mod bsdf;\npub mod flags;\npub mod lobe;\npub use bsdf::Bsdf;\npub use flags::BsdfFlags;",
        ),
        ("shading::flags", "pub struct BsdfFlags;"),
        ("shading::bsdf", "use super::lobe::Lobe;\npub enum Bsdf { L(Lobe) }"),
        ("shading::lobe", "use super::BsdfFlags;\npub struct Lobe;"),
    ]);
    assert!(violations(&tree, &["shading"]).is_empty());
}

#[test]
fn a_module_missing_from_the_layers_is_named() {
    let tree = synthetic(&[("render", ""), ("newcomer", "")]);
    assert_eq!(
        violations(&tree, &["render"]),
        vec!["newcomer: a top-level module not placed in LAYERS".to_string()]
    );
}
