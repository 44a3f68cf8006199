//! What a failed first point most likely means, named beside the failure it wraps: only a
//! cause the failure itself points to, since a wrong hint sends the user after the wrong knob.

use crate::continuation::BoxError;
use crate::continuation::corrector::CorrectorError;
use crate::shooting::ShootingError;

/// Newton got within this factor of the tolerance and stalled there: the residual is at the
/// accuracy the integration reaches on this model, not far from a solution.
const STALL_FACTOR: f64 = 100.0;

/// A first point that failed on a half-period problem without a clearer cause: a motion that
/// is not half-wave symmetric is the likely one.
#[derive(Debug, thiserror::Error)]
#[error(
    "{0} (shooting over half a period; set half_period = false if the motion is not half-wave symmetric)"
)]
struct HalfPeriodHint(BoxError);

/// A first point whose Newton iterations stalled just above the tolerance.
#[derive(Debug, thiserror::Error)]
#[error(
    "{0} (the residual stalls near the tolerance {1:e}: the integration's round-off on this model; use a larger tolerance)"
)]
struct ToleranceHint(BoxError, f64);

/// `why` with the hint its cause points to: the tolerance when Newton stalled within
/// [`STALL_FACTOR`] of it (whatever the period shot); half-period shooting when on and the
/// failure does not already say the motion is not half-wave symmetric; none otherwise.
pub(super) fn first_point(why: BoxError, half_period: bool, tolerance: f64) -> BoxError {
    let corrector = why.downcast_ref::<CorrectorError<ShootingError>>();
    let stalled = matches!(
        corrector,
        Some(CorrectorError::NoConvergence { residual, .. }) if *residual < STALL_FACTOR * tolerance
    );
    let asymmetric = matches!(
        why.downcast_ref::<ShootingError>(),
        Some(ShootingError::NotHalfWaveSymmetric(_))
    ) || matches!(
        corrector,
        Some(CorrectorError::Problem(
            ShootingError::NotHalfWaveSymmetric(_)
        ))
    );
    if stalled {
        Box::new(ToleranceHint(why, tolerance))
    } else if half_period && !asymmetric {
        Box::new(HalfPeriodHint(why))
    } else {
        why
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn no_convergence(residual: f64) -> BoxError {
        Box::new(CorrectorError::<ShootingError>::NoConvergence {
            residual,
            iterations: 8,
        })
    }

    /// The cantilever beam at tolerance 1e-14 stalls at 3.5e-14: a tolerance, not a symmetry,
    /// problem; a residual far above the tolerance keeps the half-period hint; a failure that
    /// names the asymmetry itself gets no second copy; without half-period shooting, no
    /// half-period hint.
    #[test]
    fn the_hint_follows_the_failure() {
        let text =
            |why: BoxError, half_period: bool| first_point(why, half_period, 1e-14).to_string();
        let stalled = text(no_convergence(3.51e-14), true);
        assert!(
            stalled.contains("stalls near the tolerance 1e-14"),
            "{stalled}"
        );
        assert!(!stalled.contains("half_period"), "{stalled}");
        let far = text(no_convergence(1e-3), true);
        assert!(far.contains("set half_period = false if"), "{far}");
        assert!(!text(no_convergence(1e-3), false).contains("half_period"));
        let asymmetric = text(Box::new(ShootingError::NotHalfWaveSymmetric(0.1)), true);
        assert_eq!(asymmetric.matches("half_period").count(), 1, "{asymmetric}");
        let wrapped = CorrectorError::Problem(ShootingError::NotHalfWaveSymmetric(0.1));
        let asymmetric = text(Box::new(wrapped), true);
        assert_eq!(asymmetric.matches("half_period").count(), 1, "{asymmetric}");
    }
}
