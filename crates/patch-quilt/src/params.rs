//! Configuration of a quilting run.

use mls_surface::ClusterParams;
use tps_warp::PairingParams;

use crate::error::{Result, invalid};
use crate::quilt::QuiltOutput;

/// Most relaxation rounds [`QuiltParams::validate`] accepts. The paper's post-process is a
/// few rounds, and each takes about 0.1 s on the chain mail fixture (docs/patch-quilt.md,
/// "Bounds"), so the bound catches a mistyped count that would run for months.
pub const MAX_RELAXATION_ROUNDS: usize = 100;

/// Most anchors per free corner [`QuiltParams::validate`] accepts: four corners of 1024
/// fill half of the spline's [`tps_warp::MAX_CONTROL_POINTS`], leaving the rest to the
/// pairs. The paper asks for "a few"; the default is 4.
pub const MAX_ANCHORS_PER_CORNER: usize = 1024;

/// Largest output side as a multiple of the exemplar box's side: the largest
/// [`OutputSize::Scale`] [`QuiltParams::validate`] accepts, and the bound
/// [`GeometryTexture::checked_output_extent`](crate::GeometryTexture::checked_output_extent)
/// puts on an [`OutputSize::Absolute`] size.
pub const MAX_OUTPUT_SCALE: f32 = 64.0;

/// The `field_resolution`s [`QuiltParams::validate`] accepts: nodes of `D(T_in)` along the
/// box's longer side.
pub const FIELD_RESOLUTIONS: std::ops::RangeInclusive<usize> = 8..=512;

/// Which parts of the algorithm run. [`Method::Full`] is the paper; the others are the
/// baselines the quality report compares against, computed by the same code.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
#[cfg_attr(feature = "serde", derive(serde::Serialize, serde::Deserialize))]
#[cfg_attr(feature = "serde", serde(rename_all = "snake_case"))]
pub enum Method {
    /// Search, warp and blend (paper 000 §4–§5).
    #[default]
    Full,
    /// Search for the best patch, paste it translated (no warp, no blend).
    SearchOnly,
    /// Paste randomly chosen patches translated (no search, no warp, no blend).
    RandomPlacement,
}

/// Where the warp sends each paired source point `s` with target `q`.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
#[cfg_attr(feature = "serde", derive(serde::Serialize, serde::Deserialize))]
#[cfg_attr(feature = "serde", serde(rename_all = "snake_case"))]
pub enum WarpTargets {
    /// Onto `q` exactly: the literal reading of paper 000 §5.2; the default.
    #[default]
    Exact,
    /// By the gap between the two surfaces at `s`. The pairing (Eq. 1–3)
    /// still chooses which sources of `S` take part, but a pair joins two *different
    /// random samples*, so `q − s` is mostly a tangential offset of about half a point
    /// spacing: sampling noise, not misfit. Instead `s` moves by `g − f`, where `f` is
    /// `s`'s own foot point on the exemplar's MLS surface and `g` the closer hit of the
    /// two rays from `f` along `±n_s` on `N_k`'s MLS surface (else its projection), so the
    /// spline closes exactly the gap that makes `W(S)` disagree with `N_k`'s surface — the
    /// paper's stated aim — and is the identity where the two surfaces already agree (the
    /// MLS operator's own offset on curved features cancels, both feet being measured with
    /// it). A pair with no surface of `N_k` within the pair distance limit along its normal
    /// is dropped. Not in the paper. Measured in `docs/patch-quilt-studies.md`
    /// ("Surface-gap targets after the fix", means over 8–16 seeds): lower neighbourhood
    /// and seam errors than [`WarpTargets::Exact`] on all four demo fixtures — bumpy 0.065
    /// / 0.081 against 0.077 / 0.092, chain mail 0.022 / 0.029 against 0.024 / 0.031, weave
    /// 0.019 / 0.025 against 0.024 / 0.032, flowers 0.257 / 0.350 against 0.270 / 0.364.
    /// (Before the distance-field sign fix of 2026-12-01 the flowers had measured the other
    /// way.)
    SurfaceGap,
}

/// The output's extent on the reference plane.
#[derive(Debug, Clone, Copy, PartialEq)]
#[cfg_attr(feature = "serde", derive(serde::Serialize, serde::Deserialize))]
#[cfg_attr(feature = "serde", serde(rename_all = "snake_case"))]
pub enum OutputSize {
    /// Width and depth in world units.
    Absolute(f32, f32),
    /// Multiples of the exemplar box's width and depth.
    Scale(f32),
}

/// Parameters of [`crate::quilt()`]. Lengths given as fractions are relative to the patch
/// size; the patch size is relative to the exemplar box.
#[derive(Debug, Clone, PartialEq)]
#[non_exhaustive]
#[cfg_attr(feature = "serde", derive(serde::Serialize, serde::Deserialize))]
#[cfg_attr(feature = "serde", serde(default, deny_unknown_fields))]
pub struct QuiltParams {
    /// Patch side as a fraction of the box's smaller in-plane side; default 0.4.
    pub patch_size: f32,
    /// Width `w_E` of the extra region, as a fraction of the patch; default 0.3 (the paper
    /// used 1/4 to 1/3).
    pub extra_width: f32,
    /// Overlap width as a fraction of the patch; default 1/6.
    pub overlap: f32,
    /// Nodes of `D(T_in)` along the box's longer in-plane side; default 48 (the paper used
    /// 51–84).
    pub field_resolution: usize,
    /// Relative tolerance `ε` of the candidate set; default 0.1.
    pub epsilon: f32,
    /// Distances are clamped at this many field spacings; default 4.
    pub band: f32,
    /// Pairing weights and thresholds (Eq. 2); default Table 1's height-field row. An
    /// unlimited `max_distance` (the pairing default) is replaced by
    /// [`QuiltParams::pair_distance`] field spacings.
    pub pairing: Option<PairingParams>,
    /// Largest pair length in field spacings unless `pairing` sets a finite one; default 0.5. The
    /// search has already aligned the patch to the node lattice, so true correspondences are
    /// that close; longer pairs drag points onto the wrong features (measured: 0.5 gives the
    /// lowest errors of 0.5, 1 and 1.5 on all four fixtures).
    pub pair_distance: f32,
    /// Where paired points are sent; default the paper's [`WarpTargets::Exact`].
    pub warp_targets: WarpTargets,
    /// Smoothing `λ` of the warp's thin-plate spline, relative to the patch size (the
    /// kernel `φ(r) = r` has units of length); default 0 (interpolation).
    pub smoothing: f32,
    /// Largest gap the blend closes, as a fraction of the neighbourhood's MLS support
    /// radius; default 0.25. A point whose target on `N_k` is farther away faces different
    /// geometry rather than a gap (§5.3: the gaps "should be small") and is left as it is.
    /// Measured over 8 seeds: lower neighbourhood and seam error than unlimited reach on
    /// bumpy, chain mail and flowers, equal on the weave (`docs/patch-quilt-studies.md`).
    pub blend_reach: f32,
    /// Smallest cosine between a point's normal and the normal of the neighbourhood's
    /// surface where its gap ends, for the blend to close that gap (and, with
    /// [`WarpTargets::SurfaceGap`], for the pair to count); default 0.8 (about 37°). A
    /// surface facing another way is a different sheet — another petal, the underside of a
    /// crossing thread — not the far side of a small gap, so the point is left as it is.
    /// `-1` turns the test off. Measured over 8 seeds on the flowers (surface gaps, the
    /// run's own patches): what steps 4–5 cost fell from 0.035 to 0.013; nothing
    /// measurable changed on the other fixtures (`docs/patch-quilt-studies.md`).
    pub normal_agreement: f32,
    /// Adaptive clustering limits for the target set `Q`; default `n_max` 12, `σ_max` 0.1.
    /// The paper gives no cluster size. Smaller clusters give more targets, so the spline
    /// follows the misfit more finely: measured over 8 seeds, `n_max` 4 lowered the full
    /// method's errors on the bumpy fixture and on Mount St. Helens read at three
    /// samplings (enough to beat search-only on bumpy), changed the tubes little, and
    /// raised them on a flatter reading of St. Helens at 1.6 times its size
    /// (`docs/patch-quilt-studies.md`, "Cluster size"); so 12 stays the default.
    pub clusters: ClusterParams,
    /// Anchor points mapped to themselves per free corner of `F_k`; default 4, spread
    /// through the corner's height ([`tps_warp::anchors_in_regions`]). Unless it is 0, a
    /// free corner's column is also pinned at the patch's lowest or highest z where the
    /// patch reaches far beyond the spline's control points along z, and more widely for
    /// a warp that stretches too far (the crate docs, "Choices where the paper leaves
    /// room"). At most [`MAX_ANCHORS_PER_CORNER`].
    pub anchors_per_corner: usize,
    /// The output extent; default twice the exemplar in each direction.
    pub output: OutputSize,
    /// Seed of every random choice; default 0.
    pub seed: u64,
    /// Relaxation rounds (paper §6 post-process), run on the whole synthesized texture just
    /// before it is trimmed to the output box; default 0 (off), at most
    /// [`MAX_RELAXATION_ROUNDS`].
    pub relaxation_rounds: usize,
    /// Which parts run; default the full algorithm.
    pub method: Method,
    /// A fixed seed patch (node offsets in `D(T_in)`); default random.
    pub seed_patch: Option<(usize, usize)>,
    /// Every patch's source given in advance (node offsets in `D(T_in)`, in synthesis order,
    /// e.g. [`QuiltOutput::sources`](crate::QuiltOutput::sources) of an earlier run with the
    /// same exemplar, patch geometry and output size): steps 1–3 take them instead of
    /// searching or picking at random; the other steps run as `method` says. Default none.
    ///
    /// Re-running one layout with another method isolates what the warp and blend do: the
    /// full method and [`Method::SearchOnly`] on the same layout differ only in steps 4–5.
    /// The run fails with [`QuiltError::InvalidParameter`](crate::QuiltError) when the
    /// layout's length is not the run's patch count or a source lies outside the exemplar.
    pub layout: Option<Vec<(usize, usize)>>,
}

impl Default for QuiltParams {
    fn default() -> Self {
        Self {
            patch_size: 0.4,
            extra_width: 0.3,
            overlap: 1.0 / 6.0,
            field_resolution: 48,
            epsilon: 0.1,
            band: 4.0,
            pairing: None,
            pair_distance: 0.5,
            warp_targets: WarpTargets::Exact,
            smoothing: 0.0,
            blend_reach: 0.25,
            normal_agreement: 0.8,
            clusters: ClusterParams::default().max_points(12).max_variation(0.1),
            anchors_per_corner: 4,
            output: OutputSize::Scale(2.0),
            seed: 0,
            relaxation_rounds: 0,
            method: Method::Full,
            seed_patch: None,
            layout: None,
        }
    }
}

impl QuiltParams {
    /// Sets the patch size (fraction of the box's smaller side; default 0.4).
    pub fn patch_size(mut self, fraction: f32) -> Self {
        self.patch_size = fraction;
        self
    }

    /// Sets the width `w_E` of the extra region (fraction of the patch; default 0.3).
    pub fn extra_width(mut self, fraction: f32) -> Self {
        self.extra_width = fraction;
        self
    }

    /// Sets the overlap width (fraction of the patch; default 1/6).
    pub fn overlap(mut self, fraction: f32) -> Self {
        self.overlap = fraction;
        self
    }

    /// Sets the distance clamp in field spacings (default 4).
    pub fn band(mut self, spacings: f32) -> Self {
        self.band = spacings;
        self
    }

    /// Sets the clustering limits of the target set `Q` (default `n_max` 12, `σ_max` 0.1).
    pub fn clusters(mut self, clusters: ClusterParams) -> Self {
        self.clusters = clusters;
        self
    }

    /// Sets the anchors per free corner of `F_k` (default 4, at most
    /// [`MAX_ANCHORS_PER_CORNER`]).
    pub fn anchors_per_corner(mut self, n: usize) -> Self {
        self.anchors_per_corner = n;
        self
    }

    /// Fixes the seed patch (node offsets in `D(T_in)`; default random).
    pub fn seed_patch(mut self, offset: (usize, usize)) -> Self {
        self.seed_patch = Some(offset);
        self
    }

    /// Sets the output extent (default twice the exemplar).
    pub fn output(mut self, size: OutputSize) -> Self {
        self.output = size;
        self
    }

    /// Sets the seed (default 0).
    pub fn seed(mut self, seed: u64) -> Self {
        self.seed = seed;
        self
    }

    /// Sets the method (default full).
    pub fn method(mut self, method: Method) -> Self {
        self.method = method;
        self
    }

    /// Sets the field resolution (default 48).
    pub fn field_resolution(mut self, n: usize) -> Self {
        self.field_resolution = n;
        self
    }

    /// Sets the relaxation rounds (default 0, at most [`MAX_RELAXATION_ROUNDS`]).
    pub fn relaxation_rounds(mut self, n: usize) -> Self {
        self.relaxation_rounds = n;
        self
    }

    /// Sets the pairing parameters (default Table 1 height field).
    pub fn pairing(mut self, pairing: PairingParams) -> Self {
        self.pairing = Some(pairing);
        self
    }

    /// Sets where paired points are sent (default [`WarpTargets::Exact`]).
    pub fn warp_targets(mut self, targets: WarpTargets) -> Self {
        self.warp_targets = targets;
        self
    }

    /// Sets the pair length limit in field spacings (default 0.5).
    pub fn pair_distance(mut self, spacings: f32) -> Self {
        self.pair_distance = spacings;
        self
    }

    /// Sets the warp's relative smoothing `λ` (default 0).
    pub fn smoothing(mut self, lambda: f32) -> Self {
        self.smoothing = lambda;
        self
    }

    /// Sets the blend's reach (fraction of the MLS support radius; default 0.25).
    pub fn blend_reach(mut self, fraction: f32) -> Self {
        self.blend_reach = fraction;
        self
    }

    /// Sets the normal agreement a closed gap needs (a cosine in `[-1, 1]`; default 0.8).
    pub fn normal_agreement(mut self, cosine: f32) -> Self {
        self.normal_agreement = cosine;
        self
    }

    /// Gives every patch's source in advance (see [`QuiltParams::layout`]).
    pub fn layout(mut self, sources: Vec<(usize, usize)>) -> Self {
        self.layout = Some(sources);
        self
    }

    /// The same-layout control for a run of these parameters: `output`'s patches pasted
    /// without warp or blend ([`Method::SearchOnly`] on [`QuiltOutput::sources`]), so that
    /// comparing the two runs shows what steps 4–5 did.
    pub fn same_layout_control(&self, output: &QuiltOutput) -> Self {
        self.clone()
            .method(Method::SearchOnly)
            .layout(output.sources())
    }

    /// Sets the most points per cluster of the warp's targets `Q` (default 12; see
    /// [`QuiltParams::clusters`]).
    pub fn cluster_points(mut self, n: usize) -> Self {
        self.clusters = self.clusters.max_points(n);
        self
    }

    /// Sets `ε` (default 0.1).
    pub fn epsilon(mut self, epsilon: f32) -> Self {
        self.epsilon = epsilon;
        self
    }

    /// Checks every range.
    pub fn validate(&self) -> Result<()> {
        let fraction = |name, v: f32, lo: f32, hi: f32| {
            if v.is_finite() && v > lo && v <= hi {
                Ok(())
            } else {
                Err(invalid(name, v, format!("a number in ({lo}, {hi}]")))
            }
        };
        fraction("patch_size", self.patch_size, 0.0, 1.0)?;
        fraction("extra_width", self.extra_width, 0.0, 1.0)?;
        fraction("overlap", self.overlap, 0.0, 0.5)?;
        fraction("band", self.band, 1.0, 1e3)?;
        fraction("pair_distance", self.pair_distance, 0.0, 1e3)?;
        fraction("blend_reach", self.blend_reach, 0.0, 1e3)?;
        if !(-1.0..=1.0).contains(&self.normal_agreement) {
            return Err(invalid(
                "normal_agreement",
                self.normal_agreement,
                "a cosine in [-1, 1]",
            ));
        }
        if !(self.smoothing.is_finite() && self.smoothing >= 0.0) {
            return Err(invalid("smoothing", self.smoothing, "a finite number ≥ 0"));
        }
        if self.clusters.max_points == 0 {
            return Err(invalid("clusters.max_points", 0, "at least 1 point"));
        }
        if !(self.clusters.max_variation.is_finite() && self.clusters.max_variation >= 0.0) {
            return Err(invalid(
                "clusters.max_variation",
                self.clusters.max_variation,
                "a finite number ≥ 0",
            ));
        }
        if !(self.epsilon.is_finite() && self.epsilon >= 0.0) {
            return Err(invalid("epsilon", self.epsilon, "a finite number ≥ 0"));
        }
        if !FIELD_RESOLUTIONS.contains(&self.field_resolution) {
            return Err(invalid(
                "field_resolution",
                self.field_resolution,
                "8 to 512 nodes",
            ));
        }
        match self.output {
            OutputSize::Absolute(w, h)
                if !(w.is_finite() && h.is_finite() && w > 0.0 && h > 0.0) =>
            {
                return Err(invalid(
                    "output",
                    format!("{w} x {h}"),
                    "a positive width and depth",
                ));
            }
            OutputSize::Scale(s) if !(s.is_finite() && s > 0.0 && s <= MAX_OUTPUT_SCALE) => {
                return Err(invalid("output", s, "a scale in (0, 64]"));
            }
            _ => {}
        }
        if self.relaxation_rounds > MAX_RELAXATION_ROUNDS {
            return Err(invalid(
                "relaxation_rounds",
                self.relaxation_rounds,
                format!("at most {MAX_RELAXATION_ROUNDS} rounds"),
            ));
        }
        if self.anchors_per_corner > MAX_ANCHORS_PER_CORNER {
            return Err(invalid(
                "anchors_per_corner",
                self.anchors_per_corner,
                format!("at most {MAX_ANCHORS_PER_CORNER} anchors"),
            ));
        }
        if let Some(p) = &self.pairing {
            p.validate()?;
        }
        Ok(())
    }
}
