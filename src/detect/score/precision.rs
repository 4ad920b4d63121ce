//! The SVM stage's arithmetic setting: [`ScorePrecision`] (`f32`, `i8`, `auto`) and which is faster on this CPU.

use std::str::FromStr;
use std::sync::atomic::{AtomicBool, Ordering};

use super::products::I8Kernel;
use super::weights::ScoreError;
use crate::kernels::{features, Isa};

/// Arithmetic of the SVM stage ([`crate::detect::DetectorOptions::svm`]).
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq, Hash)]
pub enum ScorePrecision {
    /// f32 products (fused multiply-adds) and window sums: OpenCV's scores within ≈1e-6.
    #[default]
    F32,
    /// Block values as u8, weights as i8, exact i32 products and window sums; scores within
    /// [`ScoreWeightsI8::error_bound`](super::ScoreWeightsI8::error_bound) of the exact ones (module docs, "8-bit path").
    I8,
}

/// Whether the start-up warning of [`ScorePrecision::warn_if_slow`] was given.
static WARNED_SLOW: AtomicBool = AtomicBool::new(false);

impl ScorePrecision {
    /// Every precision, in the order of [`Self::name`]'s list.
    pub const ALL: [Self; 2] = [Self::F32, Self::I8];

    /// The name used by the CLI (`--svm`) and the daemon config (`compute.svm`): `f32`, `i8`.
    pub fn name(self) -> &'static str {
        match self {
            Self::F32 => "f32",
            Self::I8 => "i8",
        }
    }

    /// What `auto` means on this process's kernel path ([`crate::kernels::isa`]): see
    /// [`Self::auto_for`].
    pub fn auto() -> Self {
        Self::auto_for(crate::kernels::isa())
    }

    /// The precision `auto` picks on kernel path `isa` of this CPU: [`Self::I8`] where its kernel
    /// was measured faster than the f32 one (docs/detection.md, "8-bit SVM"), [`Self::F32`]
    /// elsewhere:
    /// - AVX-512 with AVX-512 VNNI (`vpdpbusd` zmm; SVM stage 2.6–2.8x): i8;
    /// - AVX2 or AVX-512 with AVX-VNNI (`vpdpbusd` ymm; its kernel body measured through the
    ///   EVEX encoding, 4.2x the AVX2 f32 kernel): i8;
    /// - AVX2 without VNNI (`vpmaddwd` on u16 pairs; 1.1–1.6x, noisy): i8;
    /// - scalar on x86-64 (the f32 reference's `mul_add` is a libm call without FMA; i8 4x): i8;
    /// - NEON, and scalar elsewhere: f32 (the `sdot` and `smull` kernels are tested for equality
    ///   under emulation, their speed was not measured on aarch64 hardware).
    pub fn auto_for(isa: Isa) -> Self {
        if I8Kernel::for_isa(isa).faster_than_f32() {
            Self::I8
        } else {
            Self::F32
        }
    }

    /// Why this precision is slower than the other one on kernel path `isa`, naming the CPU
    /// feature that is missing; `None` when it is not known to be. Only [`Self::I8`] on NEON
    /// without the dot-product extension is: its `smull`/`sadalp` kernel issues as many
    /// multiply instructions as the f32 one, plus the widening adds. (Where `auto` picks f32 for
    /// want of a measurement, nothing is said.)
    pub fn slow_reason(self, isa: Isa) -> Option<String> {
        (self == Self::I8 && isa == Isa::Neon && isa.is_available() && !features().dotprod).then(|| {
            "svm = \"i8\" is not faster than \"f32\" here: this CPU lacks dotprod (the NEON smull/sadalp 8-bit \
             kernel issues as many multiplies as the f32 one); svm = \"auto\" picks f32"
                .to_string()
        })
    }

    /// Logs [`Self::slow_reason`] for this process's kernel path at `warn`, once per process.
    pub fn warn_if_slow(self) {
        if let Some(why) = self.slow_reason(crate::kernels::isa()) {
            if !WARNED_SLOW.swap(true, Ordering::Relaxed) {
                tracing::warn!(kernels = %crate::kernels::isa(), cpu = %features().names(), "{why}");
            }
        }
    }
}

impl std::fmt::Display for ScorePrecision {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.write_str(self.name())
    }
}

impl FromStr for ScorePrecision {
    type Err = ScoreError;
    /// `f32`, `i8`, or `auto` ([`ScorePrecision::auto`]: resolved on this CPU now); ASCII case
    /// ignored.
    fn from_str(s: &str) -> Result<Self, Self::Err> {
        if s.eq_ignore_ascii_case("auto") {
            return Ok(Self::auto());
        }
        Self::ALL
            .into_iter()
            .find(|p| p.name().eq_ignore_ascii_case(s))
            .ok_or_else(|| ScoreError::UnknownPrecision(s.to_string()))
    }
}
