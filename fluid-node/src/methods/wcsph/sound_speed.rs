//! The speed of sound a scene may ask of a weakly compressible method, against its water.
//!
//! WCSPH's pressure is Tait's p = B((ρ/ρ0)^γ − 1), B = ρ0 c0²/γ: a numerical c0 buys a larger
//! step at the price of compressibility. The default, 10·sqrt(2 g H) (ten times the free-fall
//! speed over the water's depth H; Monaghan 1994), keeps ρ within ~1 %. Far below it the scene
//! cannot run: at c0 = 1 m/s a 0.3 m column at rest is already compressed to ρ/ρ0 = 1.55 at its
//! bottom, past the density bound (1.3) before the first step, and the run stopped at step 0
//! with a message about the density (ρ/ρ0 = 1.54 at the lowest particle), not the speed of
//! sound. So a c0 below [`MIN_SOUND_SPEED_RATIO`]·sqrt(2 g H) is refused by the scene check,
//! naming the field, the compression at rest, the Mach number of water falling H, and the
//! default.

use shared::math::Real;
use shared::scene::{FieldError, Scene};

/// The smallest c0 accepted, in units of sqrt(2 g H): water falling the depth H then reaches
/// Mach 0.5, where a pair's compression ~M² approaches the density bound, and the column at
/// rest is compressed by 9 % at its bottom (γ = 7), eighteen times the default's 0.5 %.
pub const MIN_SOUND_SPEED_RATIO: Real = 2.0;

/// ρ/ρ0 at the bottom of a column `depth` deep at rest under gravity `g`, by Tait's equation
/// at `c0` and `gamma`: (1 + γ g H/c0²)^(1/γ).
pub fn resting_compression(c0: Real, gamma: Real, g: Real, depth: Real) -> Real {
    (1.0 + gamma * g * depth / (c0 * c0)).powf(1.0 / gamma)
}

/// `[fluid.<name>] sound_speed` (if given) against the scene's water: refused below
/// [`MIN_SOUND_SPEED_RATIO`]·sqrt(2 g H), H the water's depth as the scene gives it (the span of
/// its `fluid.water` volumes).
pub fn check(
    name: &str,
    sound_speed: Option<Real>,
    gamma: Option<Real>,
    scene: &Scene,
) -> Option<FieldError> {
    let c0 = sound_speed.filter(|c| c.is_finite() && *c > 0.0)?;
    let (bottom, top) = scene.water_span()?;
    let depth = top - bottom;
    let g = scene.gravity.iter().map(|x| x * x).sum::<Real>().sqrt();
    let free_fall = (2.0 * g * depth).sqrt();
    let least = MIN_SOUND_SPEED_RATIO * free_fall;
    if free_fall <= 0.0 || c0 >= least {
        return None;
    }
    let gamma = gamma.unwrap_or(7.0);
    Some(FieldError::new(
        &["fluid", name, "sound_speed"],
        format!("{c0:?}"),
        &format!(
            "is below {MIN_SOUND_SPEED_RATIO}·sqrt(2 g H) = {least:.3} m/s for water H = {depth:.3} m deep: \
             at rest its bottom is compressed to ρ/ρ0 = {:.3}, and water falling H reaches Mach {:.2} \
             (a weakly compressible method needs c0 about ten times the flow's speed)",
            resting_compression(c0, gamma, g, depth),
            free_fall / c0
        ),
        &format!(
            "leave sound_speed out (the default 10·sqrt(2 g H) = {:.3} m/s), or give at least {least:.3}",
            10.0 * free_fall
        ),
    ))
}

#[cfg(test)]
mod tests {
    use super::*;

    /// At the default c0 = 10·sqrt(2 g H) the column's bottom is compressed by 0.5 %; at the
    /// least accepted, 2·sqrt(2 g H), by 9 %; at 1 m/s over 0.3 m by 55 % (past the bound 1.3).
    #[test]
    fn the_compression_at_rest_is_taits() {
        let (g, h): (Real, Real) = (9.81, 0.3);
        let ff = (2.0 * g * h).sqrt();
        let at = |c0| resting_compression(c0, 7.0, g, h);
        assert!((at(10.0 * ff) - 1.0049).abs() < 1e-4, "{}", at(10.0 * ff));
        assert!((at(2.0 * ff) - 1.0940).abs() < 1e-4, "{}", at(2.0 * ff));
        assert!((at(1.0) - 1.5511).abs() < 1e-4, "{}", at(1.0));
    }
}
