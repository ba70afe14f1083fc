//! Keeps the `ARCHITECTURE.md` files true. Across crates: every crate of the workspace depends on
//! exactly the chainsweep crates the top-level listing says, each listed before it, and only the
//! store links HDF5. Within each crate: every module imports exactly the modules its listing
//! says, and only modules listed before it (no module imports one above it, so there are no
//! cycles).

use std::collections::{BTreeMap, BTreeSet};
use std::path::{Path, PathBuf};

const CRATE: &str = env!("CARGO_MANIFEST_DIR");

/// The listing: module → the modules it imports, in layer order (lowest first).
fn listing(doc: &str) -> Vec<(String, BTreeSet<String>)> {
    let start = doc
        .find("<!-- layers -->")
        .expect("ARCHITECTURE.md has a `<!-- layers -->` marker before the listing");
    let block = &doc[start..];
    let open = block
        .find("```text\n")
        .expect("a ```text block follows the marker")
        + 8;
    let close = block[open..].find("```").expect("the block is closed") + open;
    let mut out = Vec::new();
    for line in block[open..close].lines().skip(1) {
        let mut words = line.split_whitespace();
        let Some(module) = words.next() else { continue };
        let imports: BTreeSet<String> = words
            .filter(|w| *w != "-")
            .map(|w| w.trim_end_matches(',').to_string())
            .collect();
        out.push((module.to_string(), imports));
    }
    out
}

/// Removes `//` comments (doc comments included: links are not imports) and string literals.
fn code_only(text: &str) -> String {
    let mut out = String::with_capacity(text.len());
    for line in text.lines() {
        let mut in_str = false;
        let mut prev = ' ';
        let mut chars = line.chars().peekable();
        while let Some(c) = chars.next() {
            if in_str {
                if c == '"' && prev != '\\' {
                    in_str = false;
                }
                prev = if prev == '\\' && c == '\\' { ' ' } else { c };
                continue;
            }
            if c == '/' && chars.peek() == Some(&'/') {
                break;
            }
            if c == '"' {
                in_str = true;
                prev = ' ';
                continue;
            }
            out.push(c);
        }
        out.push('\n');
    }
    out
}

/// First path segments of every `crate::…` path in `code` (`crate::{a, b::c}` gives a and b).
fn crate_imports(code: &str) -> BTreeSet<String> {
    let ident = |s: &str| -> String {
        s.chars()
            .take_while(|c| c.is_ascii_alphanumeric() || *c == '_')
            .collect()
    };
    let mut out = BTreeSet::new();
    let mut rest = code;
    while let Some(i) = rest.find("crate::") {
        let before = rest[..i].chars().last();
        rest = &rest[i + 7..];
        if before.is_some_and(|c| c.is_ascii_alphanumeric() || c == '_') {
            continue; // e.g. `other_crate::`
        }
        let after = rest.trim_start();
        if let Some(group) = after.strip_prefix('{') {
            let mut depth = 1;
            let mut item = String::new();
            for c in group.chars() {
                match c {
                    '{' => depth += 1,
                    '}' => depth -= 1,
                    _ => {}
                }
                if depth == 0 {
                    break;
                }
                if c == ',' && depth == 1 {
                    out.insert(ident(item.trim()));
                    item.clear();
                } else {
                    item.push(c);
                }
            }
            if !item.trim().is_empty() {
                out.insert(ident(item.trim()));
            }
        } else {
            out.insert(ident(after));
        }
    }
    // Items of the crate root (`crate::NUMERICS_VERSION`, `crate::EXIT_OK`) are no module.
    out.retain(|m| !m.is_empty() && !m.starts_with(|c: char| c.is_ascii_uppercase()));
    out
}

fn rust_files(dir: &Path, out: &mut Vec<PathBuf>) {
    for entry in std::fs::read_dir(dir).unwrap() {
        let path = entry.unwrap().path();
        if path.is_dir() {
            rust_files(&path, out);
        } else if path.extension().is_some_and(|e| e == "rs") {
            out.push(path);
        }
    }
}

/// Where each test module of `code` starts: `#[cfg(test)]`, then any attributes and comments,
/// then `mod NAME` (with any visibility); with its name and whether it is a declaration of a file
/// (`mod NAME;`) rather than an inline module.
fn test_modules(code: &str) -> Vec<(usize, String, bool)> {
    let mut out = Vec::new();
    for (at, _) in code.match_indices("#[cfg(test)]") {
        let mut rest = code[at + "#[cfg(test)]".len()..].trim_start();
        // Attributes and comments between the cfg and the module.
        loop {
            if rest.starts_with("#[") {
                let Some(end) = rest.find(']') else { break };
                rest = rest[end + 1..].trim_start();
            } else if rest.starts_with("//") {
                let end = rest.find('\n').unwrap_or(rest.len());
                rest = rest[end..].trim_start();
            } else {
                break;
            }
        }
        for vis in ["pub(crate) ", "pub(super) ", "pub "] {
            if let Some(r) = rest.strip_prefix(vis) {
                rest = r;
                break;
            }
        }
        let Some(after) = rest.strip_prefix("mod ") else {
            continue;
        };
        let name: String = after
            .chars()
            .take_while(|c| c.is_ascii_alphanumeric() || *c == '_')
            .collect();
        let declared = after[name.len()..].trim_start().starts_with(';');
        out.push((at, name, declared));
    }
    out
}

/// `code` without its inline test module (from its `#[cfg(test)]` to the end of the file, where
/// this codebase keeps it).
fn without_tests(code: &str) -> &str {
    match test_modules(code)
        .into_iter()
        .find(|(_, _, declared)| !declared)
    {
        Some((at, _, _)) => &code[..at],
        None => code,
    }
}

/// Each top-level module of `src/` (`X.rs` and everything under `X/`) and what it imports;
/// `skip_tests`: leave test modules out. `reexported`: modules of other crates the crate root
/// re-exports, which count as modules of this crate (importing nothing of it).
fn actual_imports(
    src: &Path,
    skip_tests: bool,
    reexported: &[&str],
) -> BTreeMap<String, BTreeSet<String>> {
    let mut files = Vec::new();
    rust_files(src, &mut files);
    // Files that are test modules of their own (`#[cfg(test)]\nmod X;` in the file beside them).
    let mut test_files = BTreeSet::new();
    for f in &files {
        let text = std::fs::read_to_string(f).unwrap();
        for (_, name, declared) in test_modules(&text) {
            if declared {
                test_files.insert(f.with_file_name(format!("{name}.rs")));
            }
        }
    }
    let mut out: BTreeMap<String, BTreeSet<String>> = BTreeMap::new();
    for f in files {
        if skip_tests && test_files.contains(&f) {
            continue;
        }
        let rel = f.strip_prefix(src).unwrap();
        let first = rel
            .components()
            .next()
            .unwrap()
            .as_os_str()
            .to_string_lossy();
        let module = first.trim_end_matches(".rs").to_string();
        if module == "lib" || module == "main" {
            continue;
        }
        let text = std::fs::read_to_string(&f).unwrap();
        let text = if skip_tests {
            without_tests(&text)
        } else {
            &text
        };
        let code = code_only(text);
        let imports = out.entry(module.clone()).or_default();
        imports.extend(crate_imports(&code).into_iter().filter(|m| *m != module));
    }
    for m in reexported {
        out.entry(m.to_string()).or_default();
    }
    // Items of the crate root that are no module (exported macros) are no layer.
    let modules: BTreeSet<String> = out.keys().cloned().collect();
    for imports in out.values_mut() {
        imports.retain(|m| modules.contains(m));
    }
    out
}

/// Every violation of `listing` by `actual`, in words.
fn violations(
    listing: &[(String, BTreeSet<String>)],
    actual: &BTreeMap<String, BTreeSet<String>>,
) -> Vec<String> {
    let mut bad = Vec::new();
    let position: BTreeMap<&str, usize> = listing
        .iter()
        .enumerate()
        .map(|(i, (m, _))| (m.as_str(), i))
        .collect();
    for (module, imports) in actual {
        let Some(&at) = position.get(module.as_str()) else {
            bad.push(format!("module `{module}` is not in the listing"));
            continue;
        };
        for m in imports {
            match position.get(m.as_str()) {
                None => bad.push(format!(
                    "`{module}` imports `{m}`, which is not in the listing"
                )),
                Some(&j) if j >= at => bad.push(format!(
                    "`{module}` imports `{m}`, which is not below it in the listing"
                )),
                _ => {}
            }
        }
        let listed = &listing[at].1;
        if listed != imports {
            bad.push(format!(
                "`{module}` imports {imports:?}, the listing says {listed:?}"
            ));
        }
    }
    for (m, _) in listing {
        if !actual.contains_key(m) {
            bad.push(format!(
                "the listing names `{m}`, which is no module of src/"
            ));
        }
    }
    bad
}

/// Checks the crate at `dir` (relative to this one) against its ARCHITECTURE.md listing, which
/// must name at least `least` modules; `skip_tests`: leave its test modules out; `reexported`:
/// the modules of other crates its root re-exports, listed as its lowest layers.
fn check_crate(dir: &str, skip_tests: bool, least: usize, reexported: &[&str]) {
    let root = Path::new(CRATE).join(dir);
    let doc = std::fs::read_to_string(root.join("ARCHITECTURE.md")).unwrap();
    let listing = listing(&doc);
    assert!(listing.len() >= least, "listing too short: {listing:?}");
    let actual = actual_imports(&root.join("src"), skip_tests, reexported);
    let bad = violations(&listing, &actual);
    assert!(
        bad.is_empty(),
        "{dir}/ARCHITECTURE.md and {dir}/src/ disagree:\n  {}",
        bad.join("\n  ")
    );
}

/// The top-level listing of crates: (package name, folder, the chainsweep crates it depends on).
fn crate_listing(doc: &str) -> Vec<(String, String, BTreeSet<String>)> {
    let start = doc
        .find("<!-- crates -->")
        .expect("ARCHITECTURE.md has a `<!-- crates -->` marker before the listing of crates");
    let block = &doc[start..];
    let open = block.find("```text\n").expect("a ```text block follows") + 8;
    let close = block[open..].find("```").expect("the block is closed") + open;
    block[open..close]
        .lines()
        .skip(1)
        .filter_map(|line| {
            let mut words = line.split_whitespace();
            let name = words.next()?.to_string();
            let folder = words.next()?.to_string();
            let deps = words.filter(|w| *w != "-").map(String::from).collect();
            Some((name, folder, deps))
        })
        .collect()
}

/// The package name of a Cargo.toml, the names of the dependencies it links (`[dependencies]`,
/// `[dependencies.X]` and their `[target.….dependencies]`, not dev- or build-dependencies), and
/// whether one of them is the HDF5 library or a binding of it, whatever its key.
fn manifest(text: &str) -> (String, BTreeSet<String>, bool) {
    let mut name = String::new();
    let mut deps = BTreeSet::new();
    let mut hdf5 = false;
    let mut section = String::new();
    for line in text.lines() {
        let l = line.trim();
        if l.starts_with('[') {
            section = l.trim_matches(|c| c == '[' || c == ']').to_string();
            // `[dependencies.X]`, `[target.'cfg(…)'.dependencies.X]`: a dependency of its own.
            if let Some((head, dep)) = section.rsplit_once("dependencies.") {
                if !head.ends_with("dev-") && !head.ends_with("build-") {
                    deps.insert(dep.to_string());
                    hdf5 |= dep.contains("hdf5") || dep.contains("netcdf");
                }
            }
            continue;
        }
        let key = l.split('=').next().unwrap_or("").trim();
        if key.is_empty() || key.starts_with('#') {
            continue;
        }
        let links = section == "dependencies"
            || (section.starts_with("target.") && section.ends_with(".dependencies"));
        let in_dep_table = section.contains("dependencies.")
            && !section.contains("dev-dependencies.")
            && !section.contains("build-dependencies.");
        if section == "package" && key == "name" {
            name = l.split('"').nth(1).unwrap_or("").to_string();
        } else if links {
            // A renamed dependency (`store = { package = "chainsweep-store", … }`) by its package.
            let package = l
                .split("package = \"")
                .nth(1)
                .and_then(|r| r.split('"').next());
            deps.insert(package.unwrap_or(key).to_string());
            hdf5 |= key.contains("hdf5") || key.contains("netcdf") || l.contains("\"hdf5");
        } else if in_dep_table && key == "package" {
            hdf5 |= l.contains("hdf5") || l.contains("netcdf");
        }
    }
    (name, deps, hdf5)
}

/// The workspace's members (its `members = [ … ]` array, on one line or several).
fn members(workspace: &str) -> Vec<String> {
    let start = workspace
        .find("members")
        .expect("the workspace lists its members");
    let open = workspace[start..].find('[').unwrap() + start;
    let close = workspace[open..].find(']').unwrap() + open;
    workspace[open..close]
        .split('"')
        .skip(1)
        .step_by(2)
        .map(String::from)
        .collect()
}

#[test]
fn the_crates_depend_only_on_those_listed_before_them_and_only_the_store_links_hdf5() {
    let root = Path::new(CRATE).join("../..");
    let doc = std::fs::read_to_string(root.join("ARCHITECTURE.md")).unwrap();
    let listing = crate_listing(&doc);
    let workspace = std::fs::read_to_string(root.join("Cargo.toml")).unwrap();
    let members = members(&workspace);
    let mut bad = Vec::new();
    let mut seen: Vec<String> = Vec::new();
    for (name, folder, listed) in &listing {
        if !members.contains(folder) {
            bad.push(format!("{folder} is no member of the workspace"));
        }
        let text = std::fs::read_to_string(root.join(folder).join("Cargo.toml")).unwrap();
        let (package, deps, links_hdf5) = manifest(&text);
        if &package != name {
            bad.push(format!(
                "{folder}/Cargo.toml names {package}, the listing {name}"
            ));
        }
        let ours: BTreeSet<String> = deps
            .iter()
            .filter(|d| d.starts_with("chainsweep"))
            .cloned()
            .collect();
        if &ours != listed {
            bad.push(format!(
                "{name} depends on {ours:?}, the listing says {listed:?}"
            ));
        }
        for d in &ours {
            if !seen.contains(d) {
                bad.push(format!(
                    "{name} depends on {d}, which is not listed before it"
                ));
            }
        }
        if links_hdf5 != (name == "chainsweep-store") {
            bad.push(format!(
                "{name}: links HDF5 {links_hdf5}, but only the store does"
            ));
        }
        seen.push(name.clone());
    }
    for member in &members {
        if !listing.iter().any(|(_, folder, _)| folder == member) {
            bad.push(format!(
                "the workspace member {member} is not in the listing"
            ));
        }
    }
    assert!(listing.len() >= 7, "listing too short: {listing:?}");
    assert!(
        bad.is_empty(),
        "ARCHITECTURE.md and the crates disagree:\n  {}",
        bad.join("\n  ")
    );
}

#[test]
fn the_engines_modules_import_only_what_its_listing_says_and_only_from_below() {
    // The sweep crate's modules and the store, re-exported under their names: each module of
    // the engine still says which of them it uses.
    let lib = std::fs::read_to_string(Path::new(CRATE).join("src/lib.rs")).unwrap();
    let reexported = reexported_modules(&code_only(&lib));
    for m in ["error", "sweep", "grid", "store"] {
        assert!(reexported.iter().any(|r| r == m), "{m} in {reexported:?}");
    }
    let names: Vec<&str> = reexported.iter().map(String::as_str).collect();
    check_crate(".", false, 12, &names);
}

/// The modules of other chainsweep crates the engine's root re-exports: `pub use
/// chainsweep_x::{a, b};` gives those of `a`, `b` that are modules of `crates/x` (a file or a
/// folder of its `src/`; constants and functions beside them are none), `pub use chainsweep_x as
/// y;` gives `y`.
fn reexported_modules(root: &str) -> Vec<String> {
    let mut out = Vec::new();
    let mut rest = root;
    while let Some(at) = rest.find("pub use chainsweep_") {
        rest = &rest[at + "pub use chainsweep_".len()..];
        let end = rest.find(';').unwrap();
        let item = &rest[..end];
        rest = &rest[end..];
        if let Some((_, alias)) = item.split_once(" as ") {
            out.push(alias.trim().to_string());
        } else if let Some((krate, group)) = item.split_once("::{") {
            let src = Path::new(CRATE).join("..").join(krate).join("src");
            let names = group.trim_end_matches('}').split(',').map(str::trim);
            for name in names.filter(|n| !n.is_empty()) {
                if src.join(format!("{name}.rs")).is_file() || src.join(name).is_dir() {
                    out.push(name.to_string());
                }
            }
        }
    }
    out
}

#[test]
fn the_sweep_crates_modules_import_only_what_its_listing_says_and_only_from_below() {
    check_crate("../sweep", false, 7, &[]);
}

#[test]
fn the_stores_modules_import_only_what_its_listing_says_and_only_from_below() {
    check_crate("../store", false, 6, &[]);
}

#[test]
fn the_solvers_modules_import_only_what_its_listing_says_and_only_from_below() {
    check_crate("../solver", true, 8, &[]);
}

#[test]
fn the_command_lines_modules_import_only_what_its_listing_says_and_only_from_below() {
    check_crate("../cli", true, 2, &[]);
}

#[test]
fn test_modules_are_left_out_whatever_precedes_them() {
    let code = "use crate::error::Result;\n\
                #[cfg(test)]\n\
                // Dense matrices are indexed by row and column.\n\
                #[allow(clippy::needless_range_loop)]\n\
                pub(crate) mod tests {\n    use crate::engine::x;\n}\n";
    let kept = without_tests(code);
    assert_eq!(kept, "use crate::error::Result;\n");
    assert_eq!(
        crate_imports(&code_only(kept)),
        BTreeSet::from(["error".to_string()])
    );
    // A test module in a file of its own is named, whatever precedes its declaration.
    let decl = "#[cfg(test)]\n#[path = \"t.rs\"]\nmod method_tests;\nfn f() {}\n";
    assert_eq!(
        test_modules(decl),
        vec![(0, "method_tests".to_string(), true)]
    );
    assert_eq!(without_tests(decl), decl);
}

#[test]
fn the_checker_finds_imports_and_reports_an_upward_one() {
    let code = code_only(
        "use crate::{grid::Grid, store as s};\n\
         // use crate::cli;\n\
         let x = \"crate::engine\";\n\
         fn f() -> crate::error::Result<()> { crate::NUMERICS_VERSION; my_crate::x; }\n",
    );
    let found = crate_imports(&code);
    let want: BTreeSet<String> = ["error", "grid", "store"].map(String::from).into();
    assert_eq!(found, want);

    let listing = vec![
        ("error".to_string(), BTreeSet::new()),
        ("store".to_string(), BTreeSet::from(["error".to_string()])),
        ("engine".to_string(), BTreeSet::from(["store".to_string()])),
    ];
    let mut actual = BTreeMap::new();
    actual.insert("error".to_string(), BTreeSet::new());
    actual.insert(
        "store".to_string(),
        BTreeSet::from(["error".to_string(), "engine".to_string()]),
    );
    actual.insert("engine".to_string(), BTreeSet::from(["store".to_string()]));
    let bad = violations(&listing, &actual);
    assert!(
        bad.iter()
            .any(|b| b.contains("`store` imports `engine`, which is not below it")),
        "{bad:?}"
    );
    actual.get_mut("store").unwrap().remove("engine");
    assert!(violations(&listing, &actual).is_empty());
}

#[test]
fn the_manifest_reader_finds_hdf5_under_any_key_and_leaves_dev_dependencies_out() {
    let text = "[package]\nname = \"x\"\n\n[dependencies]\nserde = \"1\"\nh5 = { package = \"hdf5-metno\", version = \"0.10\" }\n\n[dev-dependencies]\nhdf5 = \"0.8\"\n";
    let (name, deps, hdf5) = manifest(text);
    assert_eq!(name, "x");
    assert_eq!(
        deps,
        BTreeSet::from(["serde".to_string(), "hdf5-metno".to_string()])
    );
    assert!(hdf5);
    let dev_only = "[package]\nname = \"y\"\n[dev-dependencies]\nhdf5 = \"0.8\"\n[dev-dependencies.netcdf]\nversion = \"1\"\n";
    assert_eq!(
        manifest(dev_only),
        ("y".to_string(), BTreeSet::new(), false)
    );
    let table =
        "[package]\nname = \"z\"\n[target.'cfg(unix)'.dependencies.blob]\npackage = \"hdf5-sys\"\n";
    let (_, deps, hdf5) = manifest(table);
    assert_eq!(deps, BTreeSet::from(["blob".to_string()]));
    assert!(hdf5);
    let renamed = "[package]\nname = \"w\"\n[dependencies]\nstore = { package = \"chainsweep-store\", path = \"../store\" }\n";
    assert_eq!(
        manifest(renamed).1,
        BTreeSet::from(["chainsweep-store".to_string()])
    );
    let ws = "[workspace]\nmembers = [\n  \"a\",\n  \"b/c\",\n]\nexclude = [\"d\"]\n";
    assert_eq!(members(ws), vec!["a".to_string(), "b/c".to_string()]);
}
