//! Configuration of the MLS surface.

use pointset_core::{KdIndex, MAX_SPAN};

use crate::error::{MlsError, Result, positive};

/// Largest [`MlsParams::support`]: a kernel truncated at 10 `h` is not truncated at all,
/// as `exp(−d²/h²)` falls below `f32`'s smallest normal number (about 1.2e-38) from
/// `d ≈ 9.3 h` on. A larger support only widens every gathering.
pub const MAX_SUPPORT: f32 = 10.0;

/// Parameters of [`crate::MlsSurface`]. Construct with `MlsParams::default()` and the
/// by-value setters; validated when the surface is built.
#[derive(Debug, Clone, PartialEq)]
#[non_exhaustive]
#[cfg_attr(feature = "serde", derive(serde::Serialize, serde::Deserialize))]
#[cfg_attr(feature = "serde", serde(default, deny_unknown_fields))]
pub struct MlsParams {
    /// Gaussian kernel size `h` in `θ(d) = exp(−d²/h²)`. `None` (the default) estimates it as
    /// [`MlsParams::kernel_spacing_factor`] × the median nearest-neighbour spacing.
    pub kernel: Option<f32>,
    /// Multiple of the spacing used when `h` is estimated; default 1.25. The support
    /// (`support · h`) must stay below the thickness of the thinnest feature, or the two
    /// sides' opposite normals cancel and the surface grows spurious handles (measured on
    /// the bunny's ears: factor 2 gives genus 2, 1.25 gives the correct genus 0).
    pub kernel_spacing_factor: f32,
    /// The kernel is truncated at `support · h` (weights beyond are zero); default 2.5,
    /// where `θ = exp(−6.25) ≈ 0.002`.
    pub support: f32,
    /// Fewer points than this inside the support means "no surface here"; default 4.
    pub min_neighbours: usize,
    /// Projection stops when `|f(x)| < tolerance · h`; default 1e-4 (single-precision
    /// arithmetic cannot go much below 1e-6 · h reliably).
    pub tolerance: f32,
    /// Projection gives up after this many iterations; default 50.
    pub max_iterations: usize,
    /// Where the kernel does not reach a query (fewer than `min_neighbours` points in the
    /// support), [`Surface::signed_distance`](pointset_core::Surface::signed_distance)
    /// falls back to the nearest sample for the distance. Its sign comes from that
    /// sample's plane when the query lies within 45° of its normal
    /// ([`SINGLE_PLANE_COSINE`](crate::SINGLE_PLANE_COSINE)), and otherwise from the tangent
    /// planes of this many nearest samples: the sum of the query's signed distances to
    /// them, each divided by its squared distance to the sample, so near planes outvote far
    /// ones. Default 8; 1 is the nearest sample's own plane always, the rule until the
    /// nineteenth session, which paper 000's geometry textures keep (their measured numbers
    /// depend on it). Measured on `geosynth reconstruct` (96 nodes, default kernel): 3000
    /// random points on a sphere with normals off by a median of 20° went from 26
    /// components to 1; a random thin closed box from 59 components to 3 and closed; a
    /// random cube from 32 to 9 (its fins, see docs/mls-surface.md, remain); the chameleon
    /// from 31 to 27. Votes of 4 or 16 planes were worse on the cube or the chameleon.
    pub fallback_sign_samples: usize,
}

impl Default for MlsParams {
    fn default() -> Self {
        Self {
            kernel: None,
            kernel_spacing_factor: 1.25,
            support: 2.5,
            min_neighbours: 4,
            tolerance: 1e-4,
            max_iterations: 50,
            fallback_sign_samples: 8,
        }
    }
}

impl MlsParams {
    /// Sets the kernel size `h` (default: estimated from the spacing).
    pub fn kernel(mut self, h: f32) -> Self {
        self.kernel = Some(h);
        self
    }

    /// Sets the kernel size `h` when one is given, or leaves it to be estimated from the
    /// spacing when `None` (a command's optional `--kernel`).
    pub fn with_kernel(mut self, h: Option<f32>) -> Self {
        self.kernel = h;
        self
    }

    /// Sets the spacing multiple for the estimated kernel (default 1.25).
    pub fn kernel_spacing_factor(mut self, factor: f32) -> Self {
        self.kernel_spacing_factor = factor;
        self
    }

    /// Sets the truncation radius in multiples of `h` (default 2.5).
    pub fn support(mut self, support: f32) -> Self {
        self.support = support;
        self
    }

    /// Sets the minimum neighbour count inside the support (default 4).
    pub fn min_neighbours(mut self, n: usize) -> Self {
        self.min_neighbours = n;
        self
    }

    /// Sets the relative convergence tolerance (default 1e-4).
    pub fn tolerance(mut self, tolerance: f32) -> Self {
        self.tolerance = tolerance;
        self
    }

    /// Sets the iteration cap (default 50).
    pub fn max_iterations(mut self, n: usize) -> Self {
        self.max_iterations = n;
        self
    }

    /// Sets how many nearest samples' planes sign a query out of the kernel's reach
    /// (default 8; 1: the nearest sample's plane).
    pub fn fallback_sign_samples(mut self, n: usize) -> Self {
        self.fallback_sign_samples = n;
        self
    }

    /// The kernel size `h` these parameters give over the points of `index`: the explicit
    /// [`MlsParams::kernel`], or [`MlsParams::kernel_spacing_factor`] × their median
    /// nearest-neighbour spacing. Errors when that spacing is 0 (all points coincide, or lie
    /// closer together than single precision resolves).
    pub fn kernel_for(&self, index: &KdIndex) -> Result<f32> {
        if let Some(h) = self.kernel {
            return Ok(h);
        }
        let spacing = index.median_spacing()?;
        if spacing <= 0.0 {
            return Err(MlsError::InvalidParameter {
                name: "kernel",
                value: "estimated 0".into(),
                expected: "an explicit kernel: the points have no spacing to estimate it from (they all coincide, or lie closer together than single precision resolves)",
            });
        }
        let h = self.kernel_spacing_factor * spacing;
        kernel_in_span(h)?;
        Ok(h)
    }

    /// Checks every field's range.
    pub fn validate(&self) -> Result<()> {
        if let Some(h) = self.kernel {
            positive("kernel", h)?;
            kernel_in_span(h)?;
        }
        positive("kernel_spacing_factor", self.kernel_spacing_factor)?;
        positive("support", self.support)?;
        if self.support > MAX_SUPPORT {
            return Err(MlsError::InvalidParameter {
                name: "support",
                value: self.support.to_string(),
                expected: "at most 10 kernels (MAX_SUPPORT): the weights are zero in f32 beyond",
            });
        }
        positive("tolerance", self.tolerance)?;
        if self.min_neighbours == 0 {
            return Err(MlsError::InvalidParameter {
                name: "min_neighbours",
                value: "0".into(),
                expected: "at least 1",
            });
        }
        if self.fallback_sign_samples == 0 {
            return Err(MlsError::InvalidParameter {
                name: "fallback_sign_samples",
                value: "0".into(),
                expected: "at least 1",
            });
        }
        if self.max_iterations == 0 {
            return Err(MlsError::InvalidParameter {
                name: "max_iterations",
                value: "0".into(),
                expected: "at least 1",
            });
        }
        Ok(())
    }
}

/// Checks a kernel `h` against [`MAX_SPAN`], the widest span the library's coordinates
/// take: squared distances in kernel units overflow `f32` from about 1.8e19 on, and a kernel
/// wider than every point set the library accepts is wider than any of them.
fn kernel_in_span(h: f32) -> Result<()> {
    if h <= MAX_SPAN {
        Ok(())
    } else {
        Err(MlsError::InvalidParameter {
            name: "kernel",
            value: format!("{h:e}"),
            expected: "at most 1e18 (pointset_core::MAX_SPAN: squared distances beyond overflow f32)",
        })
    }
}
