//! Records the git revision the command line is built from, and embeds the example sweeps.
//!
//! Here, in the thin front end, and not in the engine's crate: a new commit changes the revision,
//! and only this crate is then compiled again (the engine and the solver are not).

use std::process::Command;

fn main() {
    let rev = Command::new("git")
        .args(["describe", "--always", "--dirty", "--abbrev=12"])
        .output()
        .ok()
        .filter(|o| o.status.success())
        .map(|o| String::from_utf8_lossy(&o.stdout).trim().to_string())
        .filter(|s| !s.is_empty())
        .unwrap_or_else(|| "unknown".to_string());
    println!("cargo:rustc-env=CHAINSWEEP_GIT_REVISION={rev}");
    for p in ["../../.git/HEAD", "../../.git/refs/heads"] {
        if std::path::Path::new(p).exists() {
            println!("cargo:rerun-if-changed={p}");
        }
    }
    println!("cargo:rerun-if-changed=build.rs");
    embed_examples();
}

/// The example sweep files (and the data files they read) of the repository's `sweeps/`, embedded
/// in the binary for `chainsweep examples`: `$OUT_DIR/examples.rs` holds `EMBEDDED`, each file's
/// path relative to `sweeps/` and its bytes, in path order.
fn embed_examples() {
    let root = std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("../../sweeps");
    let mut files = Vec::new();
    let mut stack = vec![root.clone()];
    while let Some(dir) = stack.pop() {
        let Ok(entries) = std::fs::read_dir(&dir) else {
            continue;
        };
        for e in entries.flatten() {
            let p = e.path();
            if p.is_dir() {
                stack.push(p);
            } else if matches!(p.extension().and_then(|x| x.to_str()), Some("json" | "csv")) {
                files.push(p);
            }
        }
    }
    files.sort();
    let mut out = String::from("/// The embedded example files: (path under `sweeps/`, bytes).\npub static EMBEDDED: &[(&str, &[u8])] = &[\n");
    for p in &files {
        let rel = p.strip_prefix(&root).expect("under sweeps/");
        let rel = rel.to_string_lossy().replace('\\', "/");
        let abs = p.canonicalize().expect("an existing file");
        out.push_str(&format!(
            "    ({rel:?}, include_bytes!({:?})),\n",
            abs.to_string_lossy()
        ));
    }
    out.push_str("];\n");
    let dest = std::path::Path::new(&std::env::var("OUT_DIR").expect("cargo sets OUT_DIR"))
        .join("examples.rs");
    std::fs::write(dest, out).expect("OUT_DIR is writable");
    println!("cargo:rerun-if-changed=../../sweeps");
    for p in &files {
        println!("cargo:rerun-if-changed={}", p.display());
    }
}
