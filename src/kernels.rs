//! The kernel layer: one CPU-capability probe and one choice of instruction-set path for every hot
//! loop in mosaicd.
//!
//! Edge boxes are AVX2 + FMA x86-64 (Intel N100/N305, Atom x7000, AMD embedded) or aarch64 with
//! NEON (Jetson, Raspberry Pi 5, RK3588); AVX-512 is a bonus. Every kernel family (the fused
//! mosaic gradient, HOG cells and blocks, the pyramid resize, SVM scoring in f32 and 8 bits, the
//! SIFT blur and DoG) dispatches on the one [`Isa`] returned by [`isa`], so a process runs one
//! path throughout and a benchmark can name it.
//!
//! - The CPU is probed once ([`features`]) and the path chosen once ([`isa`]): the widest path the
//!   CPU supports, or the one the environment variable `MOSAICD_KERNELS` names (`scalar`, `avx2`,
//!   `avx512`, `neon`) when this CPU has it. That override is for tests and benchmarks: measuring
//!   the AVX2 path on a CPU that also has AVX-512, or the scalar oracle anywhere.
//! - [`Isa::Scalar`] is the oracle: the straightforward code compiled for the baseline target
//!   (SSE2 on x86-64, NEON-less codegen is not possible on aarch64, where the baseline includes
//!   NEON registers but our scalar code uses no intrinsics). Every other path equals it bit for
//!   bit where the kernel is integer, and within a bound stated beside the kernel where it is
//!   float; tests loop over [`Isa::available`].
//! - Intrinsics live in per-ISA files beside the algorithm (`…/kernels/{avx2,avx512,neon}.rs`);
//!   algorithm files hold none.
//!
//! Sub-features that only some kernels use (AVX-512 VNNI, AVX-VNNI, the aarch64 dot product) are
//! read from [`features`] by that kernel, inside the path [`isa`] chose.

use std::fmt;
use std::sync::OnceLock;

/// An instruction-set path of the kernels.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash, PartialOrd, Ord)]
pub enum Isa {
    /// Portable code for the baseline target: the oracle every other path is tested against.
    Scalar,
    /// x86-64 with AVX2, FMA and F16C (every AVX2 edge CPU has all three).
    Avx2,
    /// x86-64 with AVX-512 F, BW and VL on top of the AVX2 set.
    Avx512,
    /// aarch64 with Advanced SIMD (NEON), which every aarch64 CPU has.
    Neon,
}

impl Isa {
    /// Every path, in order of preference from the narrowest.
    pub const ALL: [Isa; 4] = [Isa::Scalar, Isa::Avx2, Isa::Avx512, Isa::Neon];

    /// The name used by `MOSAICD_KERNELS` and printed by benchmarks.
    pub fn name(self) -> &'static str {
        match self {
            Isa::Scalar => "scalar",
            Isa::Avx2 => "avx2",
            Isa::Avx512 => "avx512",
            Isa::Neon => "neon",
        }
    }

    /// Parses a name as `MOSAICD_KERNELS` takes it.
    pub fn from_name(s: &str) -> Option<Isa> {
        Isa::ALL
            .into_iter()
            .find(|i| i.name() == s.trim().to_ascii_lowercase())
    }

    /// Whether this CPU can run the path.
    pub fn is_available(self) -> bool {
        let f = features();
        match self {
            Isa::Scalar => true,
            Isa::Avx2 => f.avx2 && f.fma && f.f16c,
            Isa::Avx512 => f.avx2 && f.fma && f.f16c && f.avx512f && f.avx512bw && f.avx512vl,
            Isa::Neon => f.neon,
        }
    }

    /// Every path this CPU can run, the scalar oracle first: what kernel-equality tests loop over.
    pub fn available() -> Vec<Isa> {
        Isa::ALL.into_iter().filter(|i| i.is_available()).collect()
    }

    /// The widest path this CPU can run.
    pub fn widest() -> Isa {
        if Isa::Avx512.is_available() {
            Isa::Avx512
        } else if Isa::Avx2.is_available() {
            Isa::Avx2
        } else if Isa::Neon.is_available() {
            Isa::Neon
        } else {
            Isa::Scalar
        }
    }
}

impl fmt::Display for Isa {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.write_str(self.name())
    }
}

/// The CPU features the kernels care about, probed once.
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq)]
pub struct CpuFeatures {
    /// x86-64 AVX2.
    pub avx2: bool,
    /// x86-64 FMA3.
    pub fma: bool,
    /// x86-64 F16C (half-precision conversions).
    pub f16c: bool,
    /// x86-64 AVX-512 Foundation.
    pub avx512f: bool,
    /// x86-64 AVX-512 Byte and Word.
    pub avx512bw: bool,
    /// x86-64 AVX-512 Vector Length extensions.
    pub avx512vl: bool,
    /// x86-64 AVX-512 VNNI (`vpdpbusd` on 512-bit registers).
    pub avx512vnni: bool,
    /// x86-64 AVX-VNNI (`vpdpbusd` on 256-bit registers, VEX-encoded: Alder Lake and later, N100).
    pub avxvnni: bool,
    /// aarch64 Advanced SIMD.
    pub neon: bool,
    /// aarch64 dot product (`sdot`/`udot`, Armv8.2 and later: Cortex-A55/A76, Jetson Orin).
    pub dotprod: bool,
}

impl CpuFeatures {
    /// Probes the running CPU.
    pub fn detect() -> CpuFeatures {
        #[allow(unused_mut)]
        let mut f = CpuFeatures::default();
        #[cfg(target_arch = "x86_64")]
        {
            use std::arch::is_x86_feature_detected as has;
            f.avx2 = has!("avx2");
            f.fma = has!("fma");
            f.f16c = has!("f16c");
            f.avx512f = has!("avx512f");
            f.avx512bw = has!("avx512bw");
            f.avx512vl = has!("avx512vl");
            f.avx512vnni = has!("avx512vnni");
            f.avxvnni = has!("avxvnni");
        }
        #[cfg(target_arch = "aarch64")]
        {
            use std::arch::is_aarch64_feature_detected as has;
            f.neon = has!("neon");
            f.dotprod = has!("dotprod");
        }
        f
    }

    /// The features present, space-separated, as benchmarks and the start-up log print them.
    pub fn names(&self) -> String {
        let all = [
            ("avx2", self.avx2),
            ("fma", self.fma),
            ("f16c", self.f16c),
            ("avx512f", self.avx512f),
            ("avx512bw", self.avx512bw),
            ("avx512vl", self.avx512vl),
            ("avx512vnni", self.avx512vnni),
            ("avxvnni", self.avxvnni),
            ("neon", self.neon),
            ("dotprod", self.dotprod),
        ];
        let v: Vec<&str> = all.iter().filter(|(_, on)| *on).map(|(n, _)| *n).collect();
        if v.is_empty() {
            "none".to_string()
        } else {
            v.join(" ")
        }
    }
}

/// The CPU's features, probed on first use and kept for the process.
pub fn features() -> &'static CpuFeatures {
    static F: OnceLock<CpuFeatures> = OnceLock::new();
    F.get_or_init(CpuFeatures::detect)
}

/// The environment variable that forces a kernel path.
pub const OVERRIDE_VAR: &str = "MOSAICD_KERNELS";

/// How the path was chosen, for the start-up log and benchmarks.
#[derive(Debug, Clone, PartialEq, Eq)]
pub enum Choice {
    /// The widest path of this CPU.
    Widest,
    /// The path `MOSAICD_KERNELS` named.
    Forced,
    /// `MOSAICD_KERNELS` named something this CPU cannot run, or no path at all; the widest
    /// path was used instead.
    Refused {
        /// What the variable said.
        asked: String,
    },
}

/// Chooses the path from the value of `MOSAICD_KERNELS` (if set).
pub fn choose(asked: Option<&str>) -> (Isa, Choice) {
    match asked {
        None => (Isa::widest(), Choice::Widest),
        Some(s) if s.trim().is_empty() => (Isa::widest(), Choice::Widest),
        Some(s) => match Isa::from_name(s) {
            Some(i) if i.is_available() => (i, Choice::Forced),
            _ => (Isa::widest(), Choice::Refused { asked: s.to_string() }),
        },
    }
}

static CHOSEN: OnceLock<(Isa, Choice)> = OnceLock::new();

/// The path every kernel family runs in this process: chosen once, on first use.
pub fn isa() -> Isa {
    chosen().0
}

/// The path and how it was chosen.
pub fn chosen() -> &'static (Isa, Choice) {
    CHOSEN.get_or_init(|| {
        let asked = std::env::var(OVERRIDE_VAR).ok();
        let c = choose(asked.as_deref());
        if let Choice::Refused { asked } = &c.1 {
            tracing::warn!(
                value = %asked,
                using = %c.0,
                available = %Isa::available().iter().map(|i| i.name()).collect::<Vec<_>>().join(","),
                "{OVERRIDE_VAR} names a path this CPU cannot run; using the widest it can"
            );
        }
        c
    })
}

/// One line naming the path and the CPU's features, for benchmarks and the start-up log:
/// `kernels avx2 (forced by MOSAICD_KERNELS) cpu: avx2 fma f16c avx512f …`.
pub fn describe() -> String {
    let (isa, how) = chosen();
    let how = match how {
        Choice::Widest => "widest available".to_string(),
        Choice::Forced => format!("forced by {OVERRIDE_VAR}"),
        Choice::Refused { asked } => format!("{OVERRIDE_VAR}={asked} not runnable here"),
    };
    format!("kernels {isa} ({how}); cpu features: {}", features().names())
}

/// Logs [`describe`] once at `info`, for start-up.
pub fn log_choice() {
    tracing::info!(kernels = %isa(), cpu = %features().names(), "{}", describe());
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn names_round_trip() {
        for i in Isa::ALL {
            assert_eq!(Isa::from_name(i.name()), Some(i));
        }
        assert_eq!(Isa::from_name(" AVX2 "), Some(Isa::Avx2));
        assert_eq!(Isa::from_name("sse"), None);
    }

    #[test]
    fn scalar_is_always_available_and_first() {
        let a = Isa::available();
        assert_eq!(a[0], Isa::Scalar);
        assert!(a.contains(&Isa::widest()));
    }

    #[test]
    fn choice_honours_only_runnable_paths() {
        assert_eq!(choose(None), (Isa::widest(), Choice::Widest));
        assert_eq!(choose(Some("scalar")), (Isa::Scalar, Choice::Forced));
        let (i, c) = choose(Some("bogus"));
        assert_eq!(i, Isa::widest());
        assert_eq!(
            c,
            Choice::Refused {
                asked: "bogus".into()
            }
        );
        // x86 and aarch64 paths exclude each other.
        let foreign = if cfg!(target_arch = "aarch64") {
            "avx2"
        } else {
            "neon"
        };
        assert!(matches!(choose(Some(foreign)).1, Choice::Refused { .. }));
    }

    #[test]
    fn wider_paths_imply_narrower_features() {
        if Isa::Avx512.is_available() {
            assert!(Isa::Avx2.is_available());
        }
        assert_eq!(Isa::Neon.is_available(), cfg!(target_arch = "aarch64"));
    }
}
