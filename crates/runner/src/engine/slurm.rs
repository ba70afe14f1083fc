//! SLURM job arrays: the `--shard` of an array task, and the job scripts of `chainsweep slurm`.
//!
//! Shards count from 1 (`--shard K/N`, files `NAME.shard-K-of-N.h5`); SLURM array tasks count
//! from 0. Array task `T` runs shard `T + 1` of `N`: `--shard slurm/N` reads `T` from
//! `SLURM_ARRAY_TASK_ID`, and `N` is written in the script (never taken from
//! `SLURM_ARRAY_TASK_COUNT`, which is 1 when a single task is re-submitted).
//!
//! `chainsweep slurm SWEEP -o OUT.h5 --shards N` writes, in `OUT.h5.slurm/`:
//! - `array.sh`: the array job (`--array=0-(N-1)`), each task `chainsweep run SWEEP --shard
//!   slurm/N -o OUT.h5.slurm/shards/NAME.shard-K-of-N.h5`;
//! - `merge.sh`: `chainsweep merge -o OUT.h5` of the N shard files, submitted with
//!   `--dependency=afterany:` the array job, so that it runs whatever the tasks' outcome and says
//!   which tasks to re-submit;
//! - `logs/`, `shards/`: the jobs' logs and the shard files.
//!
//! An adaptive ensemble runs in rounds that depend on every sample: the array's tasks run the
//! round that `OUT.h5.slurm/ensemble-round` names (`run --ensemble-round`), and `merge.sh`, after
//! merging, runs `chainsweep slurm --next-round`, which submits the next round's array and merge
//! jobs while the merged statistics are not within their tolerances and the budget allows.

use std::path::{Path, PathBuf};

use crate::error::{Error, Result};
use crate::grid::Shard;

/// The environment variable by which SLURM gives an array task its index (from 0).
pub const ARRAY_TASK_ID: &str = "SLURM_ARRAY_TASK_ID";

/// Reads a `--shard` option: `K/N` (shards from 1), or `slurm/N` for SLURM array task
/// `task_id` (the value of `SLURM_ARRAY_TASK_ID`, from 0), which runs shard `task_id + 1` of `N`.
/// An input error naming `field` otherwise.
pub fn parse_shard(text: &str, field: &str, task_id: Option<&str>) -> Result<Shard> {
    let Some(n) = text.trim().strip_prefix("slurm/") else {
        return Shard::parse(text, field);
    };
    let n: usize = n.trim().parse().ok().filter(|&n| n > 0).ok_or_else(|| {
        Error::input(
            field,
            format!("must be K/N with 1 <= K <= N, or slurm/N with N >= 1 shards, got `{text}`"),
        )
    })?;
    let Some(id) = task_id else {
        return Err(Error::input(
            field,
            format!("`{text}` takes the shard from {ARRAY_TASK_ID}, which is not set: run it as a task of a SLURM job array (or give K/N)"),
        ));
    };
    match id.trim().parse::<usize>() {
        Ok(t) if t < n => Ok(Shard { k: t + 1, n }),
        _ => Err(Error::input(
            field,
            format!("{ARRAY_TASK_ID}={id} is not an array task of `{text}`: array tasks of {n} shards are 0 to {}", n - 1),
        )),
    }
}

/// Reads a `--shard` option with `SLURM_ARRAY_TASK_ID` from the environment (see
/// [`parse_shard`]).
pub fn parse_shard_env(text: &str, field: &str) -> Result<Shard> {
    parse_shard(text, field, std::env::var(ARRAY_TASK_ID).ok().as_deref())
}

/// What `chainsweep slurm` is asked for.
#[derive(Debug, Clone, Default)]
pub struct JobRequest {
    /// The sweep file (made absolute).
    pub sweep: PathBuf,
    /// The merged output file (made absolute).
    pub output: PathBuf,
    /// Number of shards (array tasks).
    pub shards: usize,
    /// `--time` of every job, in SLURM's syntax (`1:00:00`).
    pub time: Option<String>,
    /// `--partition`.
    pub partition: Option<String>,
    /// `--cpus-per-task` of the array tasks (their parallel runs).
    pub cpus_per_task: Option<usize>,
    /// `--account`.
    pub account: Option<String>,
    /// Further `#SBATCH` arguments, each as written (`--mem=4G`, `--qos=long`).
    pub sbatch_args: Vec<String>,
    /// The `chainsweep` binary the jobs run (absolute).
    pub binary: PathBuf,
    /// The sweep is an adaptive ensemble: the array job runs the round the job folder's
    /// [`ROUND_FILE`] names, and the merge job submits the next round when one is due.
    pub adaptive: bool,
}

/// The file of a job folder naming the round of an adaptive ensemble its array tasks run (one
/// number; round 0 when absent). Written by `chainsweep slurm --next-round` before it submits a
/// round, so that a task re-submitted by hand runs the round its shards are at.
pub const ROUND_FILE: &str = "ensemble-round";

/// Records that `files`' array tasks run round `round` of the ensemble (written whole, then
/// renamed into place).
pub fn set_round(files: &JobFiles, round: usize) -> Result<()> {
    let path = files.dir.join(ROUND_FILE);
    let tmp = files.dir.join(format!("{ROUND_FILE}.tmp"));
    std::fs::write(&tmp, format!("{round}\n")).map_err(Error::io("write", &tmp))?;
    std::fs::rename(&tmp, &path).map_err(Error::io("rename", &path))
}

/// The files of a job: scripts, folders, shard files.
#[derive(Debug, Clone, PartialEq)]
pub struct JobFiles {
    /// The folder holding everything (`OUT.h5.slurm`).
    pub dir: PathBuf,
    /// The array job script.
    pub array_script: PathBuf,
    /// The merge job script.
    pub merge_script: PathBuf,
    /// The jobs' logs.
    pub logs: PathBuf,
    /// The shard files' folder.
    pub shards_dir: PathBuf,
    /// The shard files, shard 1 first.
    pub shard_files: Vec<PathBuf>,
}

/// The folder of the SLURM job files of merged output `output`: `OUT.h5.slurm`.
pub fn job_dir_of(output: &Path) -> PathBuf {
    let mut name = output.file_name().unwrap_or_default().to_os_string();
    name.push(".slurm");
    output.with_file_name(name)
}

/// The files of the job of `output` in `shards` shards, the sweep file's stem naming the shards.
pub fn job_files(sweep: &Path, output: &Path, shards: usize) -> JobFiles {
    let dir = job_dir_of(output);
    let stem = sweep
        .file_stem()
        .map(|s| s.to_string_lossy().into_owned())
        .unwrap_or_else(|| "sweep".into());
    let shards_dir = dir.join("shards");
    JobFiles {
        array_script: dir.join("array.sh"),
        merge_script: dir.join("merge.sh"),
        logs: dir.join("logs"),
        shard_files: (1..=shards)
            .map(|k| shards_dir.join(format!("{stem}.shard-{k}-of-{shards}.h5")))
            .collect(),
        shards_dir,
        dir,
    }
}

/// Quotes `s` for a POSIX shell where needed.
pub fn shell_quote(s: &str) -> String {
    let plain = !s.is_empty()
        && s.chars()
            .all(|c| c.is_ascii_alphanumeric() || "/._-+=:,@%".contains(c));
    if plain {
        s.to_string()
    } else {
        format!("'{}'", s.replace('\'', "'\\''"))
    }
}

fn q(p: &Path) -> String {
    shell_quote(&p.to_string_lossy())
}

/// The `#SBATCH` lines every job shares (time, partition, account, extra arguments).
fn common_directives(r: &JobRequest) -> Vec<String> {
    let mut lines = Vec::new();
    if let Some(t) = &r.time {
        lines.push(format!("#SBATCH --time={t}"));
    }
    if let Some(p) = &r.partition {
        lines.push(format!("#SBATCH --partition={p}"));
    }
    if let Some(a) = &r.account {
        lines.push(format!("#SBATCH --account={a}"));
    }
    for a in &r.sbatch_args {
        lines.push(format!("#SBATCH {a}"));
    }
    lines
}

/// Checks a request: a directive must be one line and an `sbatch` option.
pub fn check(r: &JobRequest) -> Result<()> {
    if r.shards == 0 {
        return Err(Error::input("--shards", "must be at least 1"));
    }
    if r.cpus_per_task == Some(0) {
        return Err(Error::input("--cpus-per-task", "must be at least 1"));
    }
    let one_line = |field: &str, v: &str| {
        if v.is_empty() || v.contains(['\n', '\r']) {
            Err(Error::input(
                field,
                format!("must be a non-empty single line, got {v:?}"),
            ))
        } else {
            Ok(())
        }
    };
    for (field, v) in [
        ("--time", &r.time),
        ("--partition", &r.partition),
        ("--account", &r.account),
    ] {
        if let Some(v) = v {
            one_line(field, v)?;
        }
    }
    for a in &r.sbatch_args {
        one_line("--sbatch-arg", a)?;
        if !a.starts_with('-') {
            return Err(Error::input(
                "--sbatch-arg",
                format!("must be an sbatch option starting with `-` (`--mem=4G`), got {a:?}"),
            ));
        }
    }
    Ok(())
}

/// The array job script.
pub fn array_script(r: &JobRequest, f: &JobFiles) -> String {
    let n = r.shards;
    let mut s = String::from("#!/bin/bash\n");
    s += &format!(
        "# Generated by `chainsweep slurm`: {n} shard(s) of {}; array task T runs shard T+1 of {n}\n",
        r.sweep.display()
    );
    s += "# into its own file, and resumes where it stopped when it runs again. Submit the whole array\n";
    s +=
        "# with `sbatch THIS`, or only some tasks with `sbatch --array=1,3 THIS`; then merge.sh.\n";
    s += &format!(
        "#SBATCH --job-name=chainsweep-{}\n",
        r.sweep.file_stem().unwrap_or_default().to_string_lossy()
    );
    s += &format!("#SBATCH --array=0-{}\n", n - 1);
    if let Some(c) = r.cpus_per_task {
        s += &format!("#SBATCH --cpus-per-task={c}\n");
    }
    s += &format!("#SBATCH --output={}/array-%A_%a.out\n", f.logs.display());
    for l in common_directives(r) {
        s += &l;
        s += "\n";
    }
    s += "set -eu\n";
    s += "# SLURM numbers array tasks from 0, chainsweep shards from 1.\n";
    s += &format!("task=${{{ARRAY_TASK_ID}:?run this script with sbatch, as a job array}}\n");
    s += "shard=$((task + 1))\n";
    s += "# On SIGTERM (time limit, scancel, preemption) chainsweep writes its file with every finished\n";
    s += "# run and exits 143; the parallel runs are SLURM_CPUS_PER_TASK (or the CPUs it may use).\n";
    let mut round = String::new();
    if r.adaptive {
        s += "# An adaptive ensemble: every task runs the round its job folder names (merge.sh submits the\n";
        s += "# next round while the statistics are not within their tolerances).\n";
        s += &format!(
            "round=$(cat {} 2>/dev/null || echo 0)\n",
            q(&f.dir.join(ROUND_FILE))
        );
        round = " --ensemble-round \"$round\"".into();
    }
    s += &format!(
        "exec {} run {}{round} --shard slurm/{n} -o {}/{}.shard-\"$shard\"-of-{n}.h5\n",
        q(&r.binary),
        q(&r.sweep),
        q(&f.shards_dir),
        shell_quote(
            &r.sweep
                .file_stem()
                .map(|s| s.to_string_lossy().into_owned())
                .unwrap_or_else(|| "sweep".into())
        ),
    );
    s
}

/// The merge job script.
pub fn merge_script(r: &JobRequest, f: &JobFiles) -> String {
    let mut s = String::from("#!/bin/bash\n");
    s += &format!(
        "# Generated by `chainsweep slurm`: merges the {} shard files into {}.\n",
        r.shards,
        r.output.display()
    );
    s += "# Submitted with --dependency=afterany on the array job: it runs whatever the tasks' outcome, and\n";
    s += "# when shards are missing or incomplete it exits 3 and says which array tasks to re-submit.\n";
    s += &format!(
        "#SBATCH --job-name=chainsweep-{}-merge\n",
        r.sweep.file_stem().unwrap_or_default().to_string_lossy()
    );
    s += "#SBATCH --cpus-per-task=1\n";
    s += &format!("#SBATCH --output={}/merge-%j.out\n", f.logs.display());
    for l in common_directives(r) {
        s += &l;
        s += "\n";
    }
    s += "set -eu\n";
    if r.adaptive {
        s += "# An adaptive ensemble: the merged round says whether another is due; `--next-round` then\n";
        s += "# submits it (array and merge jobs), or says how the ensemble ended.\n";
    }
    s += &format!(
        "{}{} merge -o {}",
        if r.adaptive { "merged=0\n" } else { "exec " },
        q(&r.binary),
        q(&r.output)
    );
    for p in &f.shard_files {
        s += " \\\n    ";
        s += &q(p);
    }
    if r.adaptive {
        s += " || merged=$?\n";
        s += "# 3: some runs failed or are pending. Failed runs are part of the round, as on one machine;\n";
        s += "# --next-round submits nothing while runs are pending (it exits 3 too).\n";
        s += "[ \"$merged\" -eq 0 ] || [ \"$merged\" -eq 3 ] || exit \"$merged\"\n";
        s += &format!(
            "exec {} slurm {} -o {} --shards {} --next-round\n",
            q(&r.binary),
            q(&r.sweep),
            q(&r.output),
            r.shards
        );
    } else {
        s += "\n";
    }
    s
}

/// Writes the job's scripts (executable) and creates the folders they need (logs, shard files,
/// the output's folder).
pub fn write_job(r: &JobRequest) -> Result<JobFiles> {
    check(r)?;
    let f = job_files(&r.sweep, &r.output, r.shards);
    for d in [
        r.output.parent().unwrap_or(Path::new(".")),
        &f.dir,
        &f.logs,
        &f.shards_dir,
    ] {
        std::fs::create_dir_all(d).map_err(Error::io("create", d))?;
    }
    for (path, text) in [
        (&f.array_script, array_script(r, &f)),
        (&f.merge_script, merge_script(r, &f)),
    ] {
        std::fs::write(path, text).map_err(Error::io("write", path))?;
        #[cfg(unix)]
        {
            use std::os::unix::fs::PermissionsExt;
            std::fs::set_permissions(path, std::fs::Permissions::from_mode(0o755))
                .map_err(Error::io("chmod", path))?;
        }
    }
    // The shard files the tasks will write, one per line: what `status` of the folder counts
    // as missing before any task has run.
    let manifest = f.dir.join(SHARD_LIST);
    let mut text = String::new();
    for p in &f.shard_files {
        text.push_str(&p.to_string_lossy());
        text.push('\n');
    }
    std::fs::write(&manifest, text).map_err(Error::io("write", &manifest))?;
    // An adaptive ensemble starts at round 0, also in a job folder that has gone further: its
    // shards resume their stored runs round by round (cheaply) and end where one machine ends,
    // whatever the sweep file now asks (a tolerance changed since would otherwise start at a
    // round one machine never reaches).
    if r.adaptive {
        set_round(&f, 0)?;
    }
    Ok(f)
}

/// The file of a job folder listing the shard files its tasks write, one path a line.
pub const SHARD_LIST: &str = "shards.txt";

/// The shard files a job folder's tasks write (`None`: the folder has no list, as folders
/// written before it was kept).
pub fn expected_shards(dir: &Path) -> Option<Vec<PathBuf>> {
    let text = std::fs::read_to_string(dir.join(SHARD_LIST)).ok()?;
    Some(
        text.lines()
            .filter(|l| !l.is_empty())
            .map(PathBuf::from)
            .collect(),
    )
}

/// The shell command that re-submits array tasks `tasks` (from 0) of `array_script`, then the
/// merge `merge_script` after them.
pub fn resubmit_command(tasks: &[usize], array_script: &Path, merge_script: &Path) -> String {
    let list: Vec<String> = tasks.iter().map(|t| t.to_string()).collect();
    format!(
        "jid=$(sbatch --parsable --array={} {}) && sbatch --dependency=afterany:${{jid%%;*}} {}",
        list.join(","),
        q(array_script),
        q(merge_script)
    )
}

/// Submits `files`' array job, then its merge job after it (`--dependency=afterany`); returns
/// both job ids.
pub fn submit(files: &JobFiles) -> Result<(String, String)> {
    let array = sbatch(&[], &files.array_script)?;
    let merge = sbatch(
        &[format!("--dependency=afterany:{array}")],
        &files.merge_script,
    )?;
    Ok((array, merge))
}

/// The round the job folder's array tasks run (see [`ROUND_FILE`]; 0 when it names none).
pub fn folder_round(files: &JobFiles) -> usize {
    std::fs::read_to_string(files.dir.join(ROUND_FILE))
        .ok()
        .and_then(|t| t.trim().parse().ok())
        .unwrap_or(0)
}

/// The environment variables `sbatch` must not inherit: a job submitted from inside another job
/// (an adaptive ensemble's merge job submits the next round) would otherwise take that job's
/// `SLURM_*` settings, its one CPU among them (`SLURM_CPUS_PER_TASK`, which the array's tasks
/// read for their parallel runs), and its `SBATCH_*` ones. `SLURM_CONF` names the cluster and
/// is kept.
fn inherited_job_variables(names: impl Iterator<Item = String>) -> Vec<String> {
    names
        .filter(|n| (n.starts_with("SLURM_") || n.starts_with("SBATCH_")) && n != "SLURM_CONF")
        .collect()
}

/// `sbatch --parsable ARGS SCRIPT`: the job id.
fn sbatch(args: &[String], script: &Path) -> Result<String> {
    let mut cmd = std::process::Command::new("sbatch");
    let names = std::env::vars_os().filter_map(|(k, _)| k.into_string().ok());
    for name in inherited_job_variables(names) {
        cmd.env_remove(name);
    }
    let out = cmd
        .arg("--parsable")
        .args(args)
        .arg(script)
        .output()
        .map_err(|e| {
            Error::Other(format!(
                "cannot run sbatch (is SLURM installed and on PATH?): {e}"
            ))
        })?;
    if !out.status.success() {
        return Err(Error::Other(format!(
            "sbatch {} failed ({}): {}",
            script.display(),
            out.status,
            String::from_utf8_lossy(&out.stderr).trim()
        )));
    }
    let text = String::from_utf8_lossy(&out.stdout);
    // `--parsable` prints `JOBID` or `JOBID;CLUSTER`.
    let id = text.trim().split(';').next().unwrap_or("").to_string();
    if id.is_empty() {
        return Err(Error::Other(format!(
            "sbatch {} printed no job id",
            script.display()
        )));
    }
    Ok(id)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn an_array_task_runs_the_shard_after_its_index() {
        assert_eq!(
            parse_shard("slurm/3", "--shard", Some("0")).unwrap(),
            Shard { k: 1, n: 3 }
        );
        assert_eq!(
            parse_shard("slurm/3", "--shard", Some("2")).unwrap(),
            Shard { k: 3, n: 3 }
        );
        // N comes from the option: a re-submitted single task still runs shard 2 of 3.
        assert_eq!(
            parse_shard("slurm/3", "--shard", Some("1")).unwrap(),
            Shard { k: 2, n: 3 }
        );
        assert_eq!(
            parse_shard("2/5", "--shard", None).unwrap(),
            Shard { k: 2, n: 5 }
        );
        for (text, id) in [
            ("slurm/3", Some("3")),
            ("slurm/3", None),
            ("slurm/0", Some("0")),
            ("slurm/x", Some("0")),
            ("slurm/3", Some("-1")),
        ] {
            let e = parse_shard(text, "--shard", id).unwrap_err().to_string();
            assert!(e.contains("--shard"), "{e}");
        }
    }

    #[test]
    fn scripts_fix_n_and_use_absolute_paths() {
        let r = JobRequest {
            sweep: "/data/sw eep.json".into(),
            output: "/res/out.h5".into(),
            shards: 4,
            time: Some("1:00:00".into()),
            cpus_per_task: Some(8),
            sbatch_args: vec!["--mem=4G".into()],
            binary: "/opt/bin/chainsweep".into(),
            ..JobRequest::default()
        };
        let f = job_files(&r.sweep, &r.output, r.shards);
        let a = array_script(&r, &f);
        assert!(a.contains("#SBATCH --array=0-3\n"), "{a}");
        assert!(a.contains("#SBATCH --cpus-per-task=8\n"));
        assert!(a.contains("#SBATCH --time=1:00:00\n"));
        assert!(a.contains("#SBATCH --mem=4G\n"));
        assert!(a.contains("exec /opt/bin/chainsweep run '/data/sw eep.json' --shard slurm/4 -o /res/out.h5.slurm/shards/'sw eep'.shard-\"$shard\"-of-4.h5"), "{a}");
        let m = merge_script(&r, &f);
        assert!(m.contains("merge -o /res/out.h5"), "{m}");
        assert!(m.contains("shard-4-of-4.h5"));
        assert_eq!(
            resubmit_command(&[1, 3], &f.array_script, &f.merge_script),
            "jid=$(sbatch --parsable --array=1,3 /res/out.h5.slurm/array.sh) && sbatch --dependency=afterany:${jid%%;*} /res/out.h5.slurm/merge.sh"
        );
        // Only an adaptive ensemble's scripts name a round or chain the next one.
        assert!(!a.contains("round"), "{a}");
        assert!(!m.contains("--next-round") && m.contains("exec /opt/bin/chainsweep merge"));
    }

    #[test]
    fn an_adaptive_ensemble_s_tasks_run_the_folder_s_round_and_its_merge_submits_the_next() {
        let r = JobRequest {
            sweep: "/data/ens.json".into(),
            output: "/res/out.h5".into(),
            shards: 3,
            binary: "/opt/bin/chainsweep".into(),
            adaptive: true,
            ..JobRequest::default()
        };
        let f = job_files(&r.sweep, &r.output, r.shards);
        let a = array_script(&r, &f);
        assert!(
            a.contains("round=$(cat /res/out.h5.slurm/ensemble-round 2>/dev/null || echo 0)\n"),
            "{a}"
        );
        assert!(
            a.contains("exec /opt/bin/chainsweep run /data/ens.json --ensemble-round \"$round\" --shard slurm/3 -o "),
            "{a}"
        );
        let m = merge_script(&r, &f);
        // The merge must not `exec`: the next round is submitted after it, when it merged (0)
        // or some runs failed or are pending (3), never after an error.
        assert!(m.contains("set -eu\n"), "{m}");
        assert!(
            m.contains("\nmerged=0\n/opt/bin/chainsweep merge -o /res/out.h5"),
            "{m}"
        );
        assert!(m.contains("shard-3-of-3.h5 || merged=$?\n"), "{m}");
        assert!(
            m.contains("[ \"$merged\" -eq 0 ] || [ \"$merged\" -eq 3 ] || exit \"$merged\"\n"),
            "{m}"
        );
        assert!(
            m.ends_with("exec /opt/bin/chainsweep slurm /data/ens.json -o /res/out.h5 --shards 3 --next-round\n"),
            "{m}"
        );
        let dir = std::env::temp_dir().join(format!("chainsweep-round-{}", std::process::id()));
        let f = JobFiles {
            dir: dir.clone(),
            ..f
        };
        std::fs::create_dir_all(&dir).unwrap();
        assert_eq!(folder_round(&f), 0, "no file: round 0");
        set_round(&f, 4).unwrap();
        assert_eq!(
            std::fs::read_to_string(dir.join(ROUND_FILE)).unwrap(),
            "4\n"
        );
        assert_eq!(folder_round(&f), 4);
        std::fs::remove_dir_all(&dir).unwrap();
    }

    #[test]
    fn a_job_submitted_from_a_job_does_not_inherit_its_settings_but_the_cluster() {
        let names = [
            "SLURM_CPUS_PER_TASK",
            "SLURM_JOB_ID",
            "SBATCH_PARTITION",
            "SLURM_CONF",
            "PATH",
            "MY_SLURM_X",
        ];
        assert_eq!(
            inherited_job_variables(names.iter().map(|s| s.to_string())),
            ["SLURM_CPUS_PER_TASK", "SLURM_JOB_ID", "SBATCH_PARTITION"]
        );
    }
}
