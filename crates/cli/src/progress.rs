//! What a terminal (or a log) shows while the engine works: a [`ProgressSink`] that draws an
//! indicatif bar on a terminal, a plain line every few seconds otherwise (nohup, SLURM, CI logs),
//! and nothing but the essentials with `--quiet`.

use std::io::IsTerminal;
use std::time::{Duration, Instant};

use indicatif::{ProgressBar, ProgressDrawTarget, ProgressState, ProgressStyle};

use chainsweep::engine::{AutoResolution, DamageReport, ProgressSink, Start};
use chainsweep::sweep::auto::describe;

enum Mode {
    Quiet,
    Bar(ProgressBar),
    Plain { every: Duration, last: Instant },
}

/// Progress of a sweep's runs.
pub struct Progress {
    mode: Mode,
    total: usize,
    done: usize,
    failed: usize,
    at_start: usize,
    start: Instant,
}

fn fmt_duration(secs: f64) -> String {
    if !secs.is_finite() {
        return "?".to_string();
    }
    let s = secs.round() as u64;
    format!("{}:{:02}:{:02}", s / 3600, (s / 60) % 60, s % 60)
}

/// A rate of runs with three significant digits (`40.5 runs/s`, `0.123 runs/s`), as the bar
/// and the plain lines show it.
fn rate_text(per_sec: f64) -> String {
    if !(per_sec.is_finite() && per_sec > 0.0) {
        return "0 runs/s".to_string();
    }
    let decimals = (2 - per_sec.log10().floor() as i32).clamp(0, 6) as usize;
    format!("{per_sec:.decimals$} runs/s")
}

impl Progress {
    /// Progress over `total` runs of which `done` (`failed` of them failed) are already finished.
    /// `plain_every` is the interval of plain progress lines.
    pub fn new(
        total: usize,
        done: usize,
        failed: usize,
        quiet: bool,
        plain_every: Duration,
    ) -> Self {
        let mode = if quiet {
            Mode::Quiet
        } else if std::io::stderr().is_terminal() {
            // Hidden until its style, position and message are set, so that no frame shows an
            // empty field.
            let bar =
                ProgressBar::with_draw_target(Some(total as u64), ProgressDrawTarget::hidden());
            bar.set_style(
                ProgressStyle::with_template(
                    "{spinner} [{elapsed_precise}] {wide_bar} {pos}/{len} runs, {msg}, {rate}, ETA {eta}",
                )
                .expect("valid template")
                .with_key("rate", |state: &ProgressState, w: &mut dyn std::fmt::Write| {
                    let _ = write!(w, "{}", rate_text(state.per_sec()));
                })
                .progress_chars("=> "),
            );
            bar.set_position(done as u64);
            bar.reset_eta();
            bar.set_message(format!("{failed} failed"));
            bar.set_draw_target(ProgressDrawTarget::stderr());
            bar.enable_steady_tick(Duration::from_millis(200));
            Mode::Bar(bar)
        } else {
            Mode::Plain {
                every: plain_every,
                last: Instant::now(),
            }
        };
        Progress {
            mode,
            total,
            done,
            failed,
            at_start: done,
            start: Instant::now(),
        }
    }

    /// Records a finished run.
    pub fn finish_run(&mut self, failed: bool) {
        self.done += 1;
        if failed {
            self.failed += 1;
        }
        if let Mode::Bar(bar) = &self.mode {
            bar.inc(1);
            bar.set_message(format!("{} failed", self.failed));
        }
        self.tick();
    }

    /// Prints a plain line if one is due.
    pub fn tick(&mut self) {
        if let Mode::Plain { every, last } = &mut self.mode {
            if last.elapsed() >= *every {
                *last = Instant::now();
                errln!("{}", self.line_text());
            }
        }
    }

    fn line_text(&self) -> String {
        let el = self.start.elapsed().as_secs_f64();
        let new = (self.done - self.at_start) as f64;
        let rate = if el > 0.0 { new / el } else { 0.0 };
        let left = (self.total - self.done) as f64;
        let eta = if rate > 0.0 { left / rate } else { f64::NAN };
        format!(
            "chainsweep: {}/{} runs done, {} failed, {}, elapsed {}, ETA {}",
            self.done,
            self.total,
            self.failed,
            rate_text(rate),
            fmt_duration(el),
            fmt_duration(eta)
        )
    }

    /// Ends the display.
    pub fn finish(&mut self) {
        match &self.mode {
            Mode::Bar(bar) => bar.finish_and_clear(),
            Mode::Plain { .. } => errln!("{}", self.line_text()),
            Mode::Quiet => {}
        }
    }

    /// Prints a line without garbling the bar.
    pub fn println(&self, line: &str) {
        match &self.mode {
            Mode::Bar(bar) => bar.println(line),
            Mode::Plain { .. } => errln!("{line}"),
            Mode::Quiet => {}
        }
    }
}

/// The command line's [`ProgressSink`]: progress on stderr, and what `integrator: auto` chose
/// (said even with `quiet`; its pilot's lines only without).
pub struct Terminal {
    quiet: bool,
    plain_every: Duration,
    runs: Option<Progress>,
}

impl Terminal {
    /// A display; `plain_every` is the interval of plain progress lines.
    pub fn new(quiet: bool, plain_every: Duration) -> Self {
        Terminal {
            quiet,
            plain_every,
            runs: None,
        }
    }
}

/// Grids of at least this many points show their expansion's progress.
pub const SHOWN_GRID_POINTS: usize = 100_000;

/// Seconds between two lines of a grid's expansion progress.
const GRID_PROGRESS_EVERY_S: f64 = 2.0;

/// The progress of a large grid's expansion on stderr (`chainsweep: expanding the grid: …`),
/// a line every few seconds; nothing for small grids or when `quiet`.
pub struct GridProgress {
    quiet: bool,
    started: Instant,
    last: std::sync::Mutex<Option<Instant>>,
}

impl GridProgress {
    /// A display of the expansion, from now.
    pub fn new(quiet: bool) -> Self {
        GridProgress {
            quiet,
            started: Instant::now(),
            last: std::sync::Mutex::new(None),
        }
    }

    /// `done` of `total` points expanded.
    pub fn show(&self, done: usize, total: usize) {
        if self.quiet || total < SHOWN_GRID_POINTS {
            return;
        }
        let mut last = self.last.lock().unwrap_or_else(|e| e.into_inner());
        let now = Instant::now();
        let due = match *last {
            None => now.duration_since(self.started).as_secs_f64() >= 0.5,
            Some(t) => now.duration_since(t).as_secs_f64() >= GRID_PROGRESS_EVERY_S,
        };
        if due || done == total && last.is_some() {
            *last = Some(now);
            errln!(
                "chainsweep: expanding the grid: {done} of {total} points ({:.0} %), {:.1} s",
                100.0 * done as f64 / total as f64,
                now.duration_since(self.started).as_secs_f64()
            );
        }
    }
}

/// How many damaged runs a report lists (it counts them all).
pub const LISTED_DAMAGE: usize = 20;

/// The lines that say what damage was found in an output file and what becomes of it (said even
/// when quiet: it changes what the sweep computes).
pub fn damage_lines(r: &DamageReport) -> Vec<String> {
    let out = r.output.display();
    let mut lines = Vec::new();
    if let Some(why) = &r.file {
        lines.push(format!("{out} is damaged: {why}"));
    }
    if let Some(why) = &r.header {
        lines.push(format!("{out} is damaged: {why}"));
    }
    if !r.restored.is_empty() {
        lines.push(format!(
            "{out}: {} damaged run(s) restored from its snapshot (nothing lost):",
            r.restored.len()
        ));
        for l in r.restored.iter().take(LISTED_DAMAGE) {
            lines.push(format!("  {}: {}", l.label, l.why));
        }
        if r.restored.len() > LISTED_DAMAGE {
            lines.push(format!("  … and {} more", r.restored.len() - LISTED_DAMAGE));
        }
    }
    if !r.lost.is_empty() {
        lines.push(format!(
            "{out}: {} run(s) cannot be read back and will be computed again:",
            r.lost.len()
        ));
        for l in r.lost.iter().take(LISTED_DAMAGE) {
            lines.push(format!("  {}: {}", l.label, l.why));
        }
        if r.lost.len() > LISTED_DAMAGE {
            lines.push(format!("  … and {} more", r.lost.len() - LISTED_DAMAGE));
        }
    }
    if let Some(why) = &r.snapshot {
        lines.push(format!("{out}: its snapshot is damaged: {why}"));
    }
    if r.file.is_some() {
        lines.push(format!(
            "{out}: the damaged file is kept in {} when the new one replaces it",
            chainsweep::store::work_dir_of(&r.output)
                .join(chainsweep::store::DAMAGED_DIR)
                .display()
        ));
    }
    lines
}

impl ProgressSink for Terminal {
    fn damage_found(&mut self, report: &DamageReport) {
        for l in damage_lines(report) {
            errln!("chainsweep: {l}");
        }
    }

    fn pilot(&mut self, line: &str) {
        if !self.quiet {
            errln!("chainsweep: auto: {line}");
        }
    }

    fn ensemble_round(&mut self, round: usize, samples: usize, runs: usize) {
        if !self.quiet {
            errln!("chainsweep: ensemble round {round}: {samples} samples per point, {runs} runs");
        }
    }

    fn auto_resolved(&mut self, resolution: AutoResolution<'_>) {
        match resolution {
            AutoResolution::Cached { choice, cache_file } => errln!(
                "chainsweep: integrator auto, target {:e}: {} (chosen earlier: {})",
                choice.target_rel_error,
                describe(&choice.integrator),
                cache_file.display()
            ),
            AutoResolution::Chosen { choice } => errln!(
                "chainsweep: integrator auto, target {:e}: chose {}",
                choice.target_rel_error,
                choice.summary()
            ),
        }
    }

    fn started(&mut self, s: &Start<'_>) {
        let runs = Progress::new(s.total, s.done, s.failed, self.quiet, self.plain_every);
        if !self.quiet && s.resumed_points > 0 {
            runs.println(&format!(
                "chainsweep: resuming {}: {} of {} runs already done",
                s.output.display(),
                s.resumed_points,
                s.points
            ));
        }
        self.runs = Some(runs);
    }

    fn run_finished(&mut self, failed: bool) {
        if let Some(r) = &mut self.runs {
            r.finish_run(failed);
        }
    }

    fn idle(&mut self) {
        if let Some(r) = &mut self.runs {
            r.tick();
        }
    }

    fn stopping(&mut self, in_flight: usize) {
        if let Some(r) = self.runs.as_ref().filter(|_| !self.quiet) {
            r.println(&format!(
                "chainsweep: stop requested: no new runs; the output holds every finished run; waiting for {in_flight} run(s) in flight (a second signal ends at once: they are then run again on resume)"
            ));
        }
    }

    fn checkpoint_failed(&mut self, message: &str) {
        // Even when quiet: the sweep stops.
        match self.runs.as_ref().filter(|_| !self.quiet) {
            Some(r) => r.println(&format!("chainsweep: error: {message}")),
            None => errln!("chainsweep: error: {message}"),
        }
    }

    fn runs_ended(&mut self) {
        if let Some(r) = &mut self.runs {
            r.finish();
        }
    }
}

#[cfg(test)]
mod tests {
    use super::rate_text;

    #[test]
    fn rates_show_three_significant_digits() {
        assert_eq!(rate_text(40.5194), "40.5 runs/s");
        assert_eq!(rate_text(1234.6), "1235 runs/s");
        assert_eq!(rate_text(0.12345), "0.123 runs/s");
        assert_eq!(rate_text(7.0), "7.00 runs/s");
        assert_eq!(rate_text(0.0), "0 runs/s");
        assert_eq!(rate_text(f64::NAN), "0 runs/s");
    }
}
