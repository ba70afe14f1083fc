//! Records the solver crate's version (stored with every run, part of its identity).

fn main() {
    println!(
        "cargo:rustc-env=CHAINSWEEP_SOLVER_VERSION={}",
        solver_version()
    );
    println!("cargo:rerun-if-changed=../solver/Cargo.toml");
    println!("cargo:rerun-if-changed=../../Cargo.toml");
    println!("cargo:rerun-if-changed=build.rs");
}

/// The solver crate's version: its own `version = "…"`, or the workspace's when it inherits it.
fn solver_version() -> String {
    let read = |p: &str| std::fs::read_to_string(p).unwrap_or_default();
    let version_in = |text: &str, section: &str| -> Option<String> {
        let mut in_section = false;
        for line in text.lines() {
            let l = line.trim();
            if l.starts_with('[') {
                in_section = l == section;
                continue;
            }
            if in_section {
                if let Some(rest) = l.strip_prefix("version") {
                    let rest = rest.trim_start();
                    if let Some(v) = rest.strip_prefix('=') {
                        let v = v.trim().trim_matches('"');
                        if !v.is_empty() {
                            return Some(v.to_string());
                        }
                    }
                }
            }
        }
        None
    };
    let solver = read("../solver/Cargo.toml");
    version_in(&solver, "[package]")
        .or_else(|| version_in(&read("../../Cargo.toml"), "[workspace.package]"))
        .unwrap_or_else(|| "unknown".to_string())
}
