//! # chainsweep-cpu
//!
//! Run-time CPU dispatch for chainsweep's hot kernels, so that one portable binary (built without
//! `-C target-cpu=native`) runs on every x86-64 machine and still uses the vector units and the
//! fused multiply-add of the machine it runs on.
//!
//! A hot loop is written once, as a [`Kernel`]: a value whose [`Kernel::run`] is
//! `#[inline(always)]` and generic over how it multiplies and adds ([`MulAdd`]). [`dispatch`] calls
//! it through a trampoline compiled for the [`Level`] chosen for this process, into which the
//! kernel is inlined: LLVM then vectorises it for that instruction set.
//!
//! | level | instruction sets | `MulAdd` |
//! |---|---|---|
//! | [`Level::Avx512`] | AVX-512F/VL, AVX2, FMA | [`Fused`] |
//! | [`Level::Avx2`] | AVX2, FMA (x86-64-v3: Intel Haswell and AMD Zen on) | [`Fused`] |
//! | [`Level::AvxFma`] | AVX, FMA without AVX2 (AMD Piledriver, Steamroller) | [`Fused`] |
//! | [`Level::Portable`] | the target's baseline (x86-64: SSE2); every non-x86-64 target | [`Separate`] |
//!
//! **Reproducibility.** Rust never reassociates or contracts floating-point arithmetic, so a kernel
//! computes the same operations in the same order whatever the vector width: the three fused
//! levels give bitwise identical results. [`Level::Portable`] rounds `a·b + c` twice where the
//! others round once, so its results differ in the last bits of each such operation (and, through
//! an adaptive integrator's step-size choices, by up to about the integrator's tolerance). Its
//! results are the same on every machine, so pinning it (below) on any machine reproduces what a
//! machine without FMA computes. A software `fma` (what `f64::mul_add` compiles to without
//! hardware FMA, ten times slower) is never used.
//!
//! **Choosing the level.** The best level the CPU supports, detected once per process, unless the
//! environment variable [`ENV_VAR`] (`CHAINSWEEP_CPU`) names one (`portable`, `avx-fma`, `avx2`,
//! `avx512`) or the program calls [`force`]. Asking for a level the CPU does not support is an
//! error, never an illegal instruction.
//!
//! ```
//! use chainsweep_cpu::{dispatch, Kernel, MulAdd};
//!
//! /// `y += a x`, element by element.
//! struct Axpy<'a> {
//!     a: f64,
//!     x: &'a [f64],
//!     y: &'a mut [f64],
//! }
//!
//! impl Kernel for Axpy<'_> {
//!     type Output = ();
//!     #[inline(always)]
//!     fn run<M: MulAdd>(self) {
//!         for (y, x) in self.y.iter_mut().zip(self.x) {
//!             *y = M::mul_add(self.a, *x, *y);
//!         }
//!     }
//! }
//!
//! let x = [1.0, 2.0, 3.0];
//! let mut y = [1.0; 3];
//! dispatch(Axpy { a: 2.0, x: &x, y: &mut y });
//! assert_eq!(y, [3.0, 5.0, 7.0]);
//! ```
#![deny(missing_docs)]
#![deny(unsafe_op_in_unsafe_fn)]

use std::sync::atomic::{AtomicU8, Ordering};

/// The environment variable that pins the level for a process: `portable`, `avx-fma`, `avx2` or
/// `avx512`.
pub const ENV_VAR: &str = "CHAINSWEEP_CPU";

/// A code path, from the most portable to the widest.
#[derive(Debug, Clone, Copy, PartialEq, Eq, PartialOrd, Ord, Hash)]
pub enum Level {
    /// The target's baseline instruction set (x86-64: SSE2, 128-bit vectors); multiply and add
    /// are separate, correctly rounded operations. The only level on other architectures.
    Portable,
    /// AVX and FMA without AVX2: 256-bit floating-point vectors, fused multiply-add.
    AvxFma,
    /// AVX2 and FMA (x86-64-v3).
    Avx2,
    /// AVX-512F and AVX-512VL with AVX2 and FMA: 512-bit vectors.
    Avx512,
}

impl Level {
    /// Every level, most portable first.
    pub const ALL: [Level; 4] = [Level::Portable, Level::AvxFma, Level::Avx2, Level::Avx512];

    /// The name [`ENV_VAR`] takes.
    pub fn name(self) -> &'static str {
        match self {
            Level::Portable => "portable",
            Level::AvxFma => "avx-fma",
            Level::Avx2 => "avx2",
            Level::Avx512 => "avx512",
        }
    }

    /// The level of a name, as [`Level::name`] writes it.
    pub fn from_name(name: &str) -> Option<Level> {
        Level::ALL.into_iter().find(|l| l.name() == name)
    }

    /// Whether this level multiplies and adds with one rounding (hardware FMA).
    pub fn fused(self) -> bool {
        self != Level::Portable
    }

    /// Whether the CPU this process runs on can execute this level's code.
    pub fn is_supported(self) -> bool {
        match self {
            Level::Portable => true,
            #[cfg(target_arch = "x86_64")]
            Level::AvxFma => {
                std::arch::is_x86_feature_detected!("avx")
                    && std::arch::is_x86_feature_detected!("fma")
            }
            #[cfg(target_arch = "x86_64")]
            Level::Avx2 => {
                std::arch::is_x86_feature_detected!("avx2")
                    && std::arch::is_x86_feature_detected!("fma")
            }
            #[cfg(target_arch = "x86_64")]
            Level::Avx512 => {
                std::arch::is_x86_feature_detected!("avx512f")
                    && std::arch::is_x86_feature_detected!("avx512vl")
                    && std::arch::is_x86_feature_detected!("avx2")
                    && std::arch::is_x86_feature_detected!("fma")
            }
            #[cfg(not(target_arch = "x86_64"))]
            _ => false,
        }
    }

    /// The levels this CPU supports, most portable first.
    pub fn supported() -> Vec<Level> {
        Level::ALL
            .into_iter()
            .filter(|l| l.is_supported())
            .collect()
    }

    /// The widest level this CPU supports.
    pub fn best() -> Level {
        *Level::supported()
            .last()
            .expect("the portable level is always supported")
    }

    fn code(self) -> u8 {
        self as u8 + 1
    }

    fn from_code(code: u8) -> Option<Level> {
        Level::ALL.get(usize::from(code).checked_sub(1)?).copied()
    }
}

impl std::fmt::Display for Level {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.write_str(self.name())
    }
}

/// A level was asked for that this CPU cannot run, or one that does not exist.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct LevelError(String);

impl std::fmt::Display for LevelError {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.write_str(&self.0)
    }
}

impl std::error::Error for LevelError {}

/// The level of this process; 0 until chosen. Written only by [`level`] and [`force`], and only
/// with a level whose [`Level::is_supported`] is true: the trampolines' safety rests on that.
static LEVEL: AtomicU8 = AtomicU8::new(0);

/// The level [`ENV_VAR`] asks for, if it is set.
pub fn level_from_env() -> Result<Option<Level>, LevelError> {
    match std::env::var_os(ENV_VAR) {
        None => Ok(None),
        Some(value) => pinned_level(&value.to_string_lossy()).map(Some),
    }
}

/// The level a value of [`ENV_VAR`] names, if this CPU supports it.
fn pinned_level(value: &str) -> Result<Level, LevelError> {
    let level = Level::from_name(value.trim()).ok_or_else(|| {
        LevelError(format!(
            "{ENV_VAR}={value}: not a level; allowed values: {}",
            Level::ALL.map(Level::name).join(", ")
        ))
    })?;
    if !level.is_supported() {
        return Err(LevelError(format!(
            "{ENV_VAR}={value}: this CPU does not support it; supported here: {}",
            Level::supported()
                .into_iter()
                .map(Level::name)
                .collect::<Vec<_>>()
                .join(", ")
        )));
    }
    Ok(level)
}

/// The level kernels run at in this process: the one [`force`]d, else the one [`ENV_VAR`] names,
/// else the best the CPU supports. Chosen on the first call and kept.
///
/// # Panics
///
/// If [`ENV_VAR`] names no level or one this CPU does not support (with a message that lists the
/// allowed values): a pinned level is never silently replaced by another.
#[inline]
pub fn level() -> Level {
    match Level::from_code(LEVEL.load(Ordering::Relaxed)) {
        Some(level) => level,
        None => choose(),
    }
}

#[cold]
fn choose() -> Level {
    let level = match level_from_env() {
        Ok(pinned) => pinned.unwrap_or_else(Level::best),
        Err(e) => panic!("{e}"),
    };
    // A concurrent first call chooses the same level, or a forced one wins.
    let _ = LEVEL.compare_exchange(0, level.code(), Ordering::Relaxed, Ordering::Relaxed);
    Level::from_code(LEVEL.load(Ordering::Relaxed)).expect("a level was stored")
}

/// Runs every later kernel of this process at `level` (tests, benchmarks; the environment variable
/// is the way for users). Refused for a level this CPU does not support.
pub fn force(level: Level) -> Result<(), LevelError> {
    if !level.is_supported() {
        return Err(LevelError(format!(
            "level {level} is not supported by this CPU"
        )));
    }
    LEVEL.store(level.code(), Ordering::Relaxed);
    Ok(())
}

/// How a kernel computes `a·b + c`.
pub trait MulAdd {
    /// Whether `mul_add` rounds once.
    const FUSED: bool;
    /// `a·b + c`.
    fn mul_add(a: f64, b: f64, c: f64) -> f64;
}

/// `a·b + c` rounded once: the hardware fused multiply-add (used only where the CPU has one).
#[derive(Debug, Clone, Copy)]
pub struct Fused;

impl MulAdd for Fused {
    const FUSED: bool = true;
    #[inline(always)]
    fn mul_add(a: f64, b: f64, c: f64) -> f64 {
        a.mul_add(b, c)
    }
}

/// `a·b + c` as a multiplication and an addition, each rounded.
#[derive(Debug, Clone, Copy)]
pub struct Separate;

impl MulAdd for Separate {
    const FUSED: bool = false;
    #[inline(always)]
    fn mul_add(a: f64, b: f64, c: f64) -> f64 {
        a * b + c
    }
}

/// A hot loop, compiled once per [`Level`] by [`dispatch`].
///
/// Implementations must mark `run` `#[inline(always)]`, and so every function of their own that
/// it calls with the `MulAdd` parameter: only code inlined into the trampoline is compiled for the
/// level's instruction set (a call left out of line runs baseline code, and [`Fused`] there would
/// be a slow software `fma`).
pub trait Kernel {
    /// What the kernel returns.
    type Output;
    /// The kernel's body.
    fn run<M: MulAdd>(self) -> Self::Output;
}

/// Runs `kernel` with the code of this process's [`level`].
#[inline]
pub fn dispatch<K: Kernel>(kernel: K) -> K::Output {
    match level() {
        Level::Portable => kernel.run::<Separate>(),
        #[cfg(target_arch = "x86_64")]
        // SAFETY: `level()` returns only levels that `Level::is_supported` confirmed on this CPU
        // (see `LEVEL`), and AvxFma's support check covers exactly the features `avx_fma` enables.
        Level::AvxFma => unsafe { x86::avx_fma(kernel) },
        #[cfg(target_arch = "x86_64")]
        // SAFETY: as above; Avx2's check covers `avx2` and `fma`.
        Level::Avx2 => unsafe { x86::avx2(kernel) },
        #[cfg(target_arch = "x86_64")]
        // SAFETY: as above; Avx512's check covers `avx512f`, `avx512vl`, `avx2` and `fma`.
        Level::Avx512 => unsafe { x86::avx512(kernel) },
        #[cfg(not(target_arch = "x86_64"))]
        _ => unreachable!("only the portable level is supported off x86-64"),
    }
}

/// The trampolines: the kernel inlined into a function compiled for the level's features.
#[cfg(target_arch = "x86_64")]
mod x86 {
    use super::{Fused, Kernel};

    /// # Safety
    /// The CPU must support AVX and FMA.
    #[target_feature(enable = "avx,fma")]
    #[inline]
    pub unsafe fn avx_fma<K: Kernel>(kernel: K) -> K::Output {
        kernel.run::<Fused>()
    }

    /// # Safety
    /// The CPU must support AVX2 and FMA.
    #[target_feature(enable = "avx2,fma")]
    #[inline]
    pub unsafe fn avx2<K: Kernel>(kernel: K) -> K::Output {
        kernel.run::<Fused>()
    }

    /// # Safety
    /// The CPU must support AVX-512F, AVX-512VL, AVX2 and FMA.
    #[target_feature(enable = "avx512f,avx512vl,avx2,fma")]
    #[inline]
    pub unsafe fn avx512<K: Kernel>(kernel: K) -> K::Output {
        kernel.run::<Fused>()
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Reports how the kernel it ran in multiplies and adds, and computes a product-sum whose
    /// fused and separate results differ: (1 + 2⁻³⁰)(1 − 2⁻³⁰) − 1 = −2⁻⁶⁰ exactly, while the
    /// rounded product is 1 and the separate result 0.
    struct Probe(f64, f64, f64);

    impl Kernel for Probe {
        type Output = (bool, f64);
        #[inline(always)]
        fn run<M: MulAdd>(self) -> (bool, f64) {
            (M::FUSED, M::mul_add(self.0, self.1, self.2))
        }
    }

    #[test]
    fn names_round_trip_and_portable_is_always_there() {
        for l in Level::ALL {
            assert_eq!(Level::from_name(l.name()), Some(l));
            assert_eq!(Level::from_code(l.code()), Some(l));
        }
        assert_eq!(Level::from_name("sse9"), None);
        assert_eq!(Level::from_code(0), None);
        assert!(Level::Portable.is_supported());
        assert_eq!(Level::supported()[0], Level::Portable);
    }

    #[test]
    fn the_environment_variable_names_a_supported_level_or_is_refused() {
        assert_eq!(pinned_level("portable"), Ok(Level::Portable));
        assert_eq!(pinned_level(" portable\n"), Ok(Level::Portable));
        let e = pinned_level("sse9").unwrap_err().to_string();
        assert!(
            e.contains("CHAINSWEEP_CPU=sse9") && e.contains("avx512"),
            "{e}"
        );
        for level in Level::ALL {
            match pinned_level(level.name()) {
                Ok(l) => assert!(l == level && level.is_supported()),
                Err(e) => {
                    assert!(!level.is_supported());
                    assert!(e.to_string().contains("does not support"), "{e}");
                }
            }
        }
    }

    #[test]
    fn every_supported_level_runs_its_own_arithmetic() {
        let e = 2f64.powi(-30);
        let probe = || Probe(1.0 + e, 1.0 - e, -1.0);
        for pinned in Level::supported() {
            force(pinned).unwrap();
            assert_eq!(level(), pinned);
            let (fused, value) = dispatch(probe());
            assert_eq!(fused, pinned.fused(), "{pinned}");
            let expected = if pinned.fused() { -(e * e) } else { 0.0 };
            assert_eq!(value, expected, "{pinned}");
        }
        for level in Level::ALL {
            if !level.is_supported() {
                let e = force(level).unwrap_err();
                assert!(e.to_string().contains(level.name()), "{e}");
            }
        }
        force(Level::best()).unwrap();
    }

    #[cfg(target_arch = "x86_64")]
    #[test]
    fn a_fused_level_exists_wherever_the_cpu_has_fma() {
        let fma = std::arch::is_x86_feature_detected!("fma");
        let avx = std::arch::is_x86_feature_detected!("avx");
        assert_eq!(Level::best().fused(), fma && avx);
    }
}
