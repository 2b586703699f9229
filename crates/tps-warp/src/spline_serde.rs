//! The stored form of a [`ThinPlateSpline`] (the `serde` feature): its terms, read back
//! through [`ThinPlateSpline::from_terms`]'s checks.

use glam::{DMat3, DVec3};
use serde::{Deserialize, Serialize};

use crate::{ThinPlateSpline, TpsError};

/// A spline's terms as a document spells them.
#[derive(Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub(crate) struct SplineTerms {
    centers: Vec<DVec3>,
    weights: Vec<DVec3>,
    translation: DVec3,
    linear: DMat3,
}

impl From<ThinPlateSpline> for SplineTerms {
    fn from(spline: ThinPlateSpline) -> Self {
        let (translation, linear) = spline.affine();
        Self {
            centers: spline.centers().to_vec(),
            weights: spline.weights().to_vec(),
            translation,
            linear,
        }
    }
}

impl TryFrom<SplineTerms> for ThinPlateSpline {
    type Error = TpsError;

    fn try_from(terms: SplineTerms) -> Result<Self, TpsError> {
        Self::from_terms(
            terms.centers,
            terms.weights,
            terms.translation,
            terms.linear,
        )
    }
}
