//! The sharded commands: `status` of a set of shard files and the shards left to run,
//! `merge`, and `slurm`'s job files and submission.

use std::path::Path;

use crate::progress::damage_lines;
use chainsweep::engine::merge::MergeReport;
use chainsweep::engine::slurm::{self, JobFiles, JobRequest};
use chainsweep::engine::status::{ShardSetStatus, ShardState};

/// The end of `merge`: the counts, and the shards to run again (with the command that
/// re-submits only them, when the output's SLURM job `scripts` (array, merge) exist).
pub fn merged(r: &MergeReport, output: &Path, scripts: Option<(&Path, &Path)>) {
    if r.searches {
        // (The counts of a search sweep are of its searches, as `status` gives them.)
        errln!(
            "chainsweep: merged {} shard file(s): {} search(es): {} ended, {} failed, {} unfinished → {}",
            r.shards,
            r.points,
            r.counts.ok,
            r.counts.failed,
            r.counts.pending,
            output.display()
        );
    } else {
        errln!(
            "chainsweep: merged {} shard file(s): {} runs: {}, {} pending → {}",
            r.shards,
            r.points,
            r.counts.finished_text(),
            r.counts.pending,
            output.display()
        );
    }
    for a in &r.absent {
        errln!("chainsweep: shard file not found: {}", a.display());
    }
    for d in &r.damage {
        for l in damage_lines(d) {
            errln!("chainsweep: {l}");
        }
        if !d.lost.is_empty() && d.output != output {
            errln!(
                "chainsweep: its damaged runs are pending in {}: run the command that made {} again (it computes them), then merge again",
                output.display(),
                d.output.display()
            );
        }
    }
    if let Some(set) = &r.shard_set {
        shards_to_run(set, scripts);
    }
}

/// The shards of `set` to run again: which, why, and how (SLURM array tasks count from 0).
fn shards_to_run(set: &ShardSetStatus, scripts: Option<(&Path, &Path)>) {
    let to_run = set.to_run();
    if to_run.is_empty() {
        return;
    }
    for e in set.shards.iter().filter(|e| to_run.contains(&e.k)) {
        let why = match (&e.counts, e.state) {
            (Some(c), ShardState::Pending) => format!("{} of its runs pending", c.pending),
            _ => "no shard file".to_string(),
        };
        errln!(
            "chainsweep: shard {}/{} (SLURM array task {}) is {}: {why}",
            e.k,
            set.n,
            e.k - 1,
            e.state.name()
        );
    }
    let tasks: Vec<usize> = to_run.iter().map(|k| k - 1).collect();
    let list: Vec<String> = tasks.iter().map(|t| t.to_string()).collect();
    match scripts {
        Some((array, merge)) => errln!(
            "chainsweep: to run only those array tasks again (each resumes where it stopped), then the merge:\n  {}",
            slurm::resubmit_command(&tasks, array, merge)
        ),
        None => errln!(
            "chainsweep: to run only those array tasks again (each resumes where it stopped): sbatch --array={} ARRAY_SCRIPT, then merge again; or `chainsweep run SWEEP --shard K/{}` for each shard K above",
            list.join(","),
            set.n
        ),
    }
}

/// `status` of a shard set: one line per shard.
pub fn shard_set_status(set: &ShardSetStatus, scripts: Option<(&Path, &Path)>) {
    for e in &set.shards {
        let mut detail = match (&e.counts, &e.file) {
            (Some(c), Some(f)) => format!(
                "{} runs: {}, {} pending ({})",
                c.done() + c.pending,
                c.finished_text(),
                c.pending,
                f.display()
            ),
            _ => "no shard file".to_string(),
        };
        if let Some(pid) = &e.writer {
            detail.push_str(&if pid.is_empty() {
                "; a process is writing it now".to_string()
            } else {
                format!("; process {pid} is writing it now")
            });
        }
        outln!(
            "shard {}/{} (array task {}): {:<7} {detail}",
            e.k,
            set.n,
            e.k - 1,
            e.state.name()
        );
    }
    let count = |st: ShardState| set.shards.iter().filter(|e| e.state == st).count();
    outln!(
        "{} shards: {} done, {} failed, {} running, {} pending, {} missing",
        set.n,
        count(ShardState::Done),
        count(ShardState::Failed),
        count(ShardState::Running),
        count(ShardState::Pending),
        count(ShardState::Missing)
    );
    shards_to_run(set, scripts);
}

/// `slurm`: the job files written, and how to submit them.
pub fn slurm_job(r: &JobRequest, f: &JobFiles) {
    outln!(
        "array job ({} tasks, task T runs shard T+1 of {}): {}",
        r.shards,
        r.shards,
        f.array_script.display()
    );
    outln!("merge job: {}", f.merge_script.display());
    outln!("shard files: {}/", f.shards_dir.display());
    outln!("logs: {}/", f.logs.display());
    outln!(
        "submit: jid=$(sbatch --parsable {}) && sbatch --dependency=afterany:${{jid%%;*}} {}",
        slurm::shell_quote(&f.array_script.to_string_lossy()),
        slurm::shell_quote(&f.merge_script.to_string_lossy())
    );
    outln!("status: chainsweep status {}", f.dir.display());
}

/// `slurm --submit`: the job ids.
pub fn submitted(array: &str, merge: &str, f: &JobFiles) {
    outln!(
        "submitted array job {array} and merge job {merge} (after the array, whatever its outcome)"
    );
    outln!(
        "cancel one task: scancel {array}_T; status: chainsweep status {}",
        f.dir.display()
    );
}
