//! Water over a terrain read from a file (`[[terrain]]`): still water in a DEM basin holds
//! hydrostatic pressure within the still-water tolerance, and no particle crosses the bed.

use fluid_node::validation::*;

#[test]
fn wcsph_still_water_in_a_dem_basin_is_hydrostatic_and_stays_above_the_bed() {
    let (depth, dx) = (0.1, 0.1 / 8.0);
    let r = terrain_basin("wcsph", depth, dx, 0.3).unwrap();
    let s = &r.still;
    eprintln!(
        "terrain basin: error {:.4} of ρgH, surface {:.4}, {} particles, {} boundary, {} steps, deepest {:.2e} m, probes {:?}",
        s.max_error, s.surface, s.particles, r.boundary, s.steps, r.deepest, s.probes
    );
    assert!(
        s.max_error <= HYDROSTATIC_TOLERANCE,
        "pressure error {:.3} of ρgH: {:?}",
        s.max_error,
        s.probes
    );
    // A quarter spacing: the fill meets the terrain's boundary particles, so the water has no
    // dry layer along the curved bed to settle into (measured +0.03 dx; with the old dx/2
    // layer −0.38 dx).
    assert!(
        (s.surface - depth).abs() <= 0.25 * dx,
        "surface {} against {depth}",
        s.surface
    );
    assert_eq!(
        r.crossed, 0,
        "particles under the bed, the deepest {} m",
        r.deepest
    );
    assert!(
        r.boundary > 1000,
        "terrain boundary particles: {}",
        r.boundary
    );
}
