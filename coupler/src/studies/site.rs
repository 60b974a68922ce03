//! `coupler make-site`: the synthetic reservoir of `scenes/fjord.toml`, written as an ESRI ASCII
//! grid (`.asc`) by a formula in this file, so the example needs no download.
//!
//! A 400 m × 260 m reservoir: a flat-floored valley along x (floor at z = −40 m, 40 m wide,
//! centred at y = 120 m) between a 35° south flank (the slide's, up to z = 30 m at y = 0) and a
//! 25° north flank (the far shore, up to z = 16 m at y = 260 m), closed at both ends by 30°
//! slopes rising from 100 m inside each end (to z = 17.7 m). The still water is at z = 0.

use clap::Args;
use shared::math::readable;
use shared::terrain::dem::Grid;
use std::path::PathBuf;

/// Extent of the site [m] (x, y) and its lowest point.
pub const LENGTH: f64 = 400.0;
pub const WIDTH: f64 = 260.0;
pub const FLOOR: f64 = -40.0;
/// Slope of the south (slide) flank and of the far shore [deg].
pub const SOUTH_SLOPE: f64 = 35.0;
pub const NORTH_SLOPE: f64 = 25.0;
/// Cell size of the committed grid `scenes/fjord/fjord.asc` [m].
pub const SCENE_CELL: f64 = 4.0;

/// Elevation of the site at (x, y) [m].
pub fn elevation(x: f64, y: f64) -> f64 {
    let (centre, half_floor) = (120.0, 20.0);
    let across = if y < centre - half_floor {
        (centre - half_floor - y) * SOUTH_SLOPE.to_radians().tan()
    } else if y > centre + half_floor {
        (y - centre - half_floor) * NORTH_SLOPE.to_radians().tan()
    } else {
        0.0
    };
    // The ends: 30° slopes rising from 100 m inside each end.
    let end =
        ((x - 0.5 * LENGTH).abs() - (0.5 * LENGTH - 100.0)).max(0.0) * 30f64.to_radians().tan();
    FLOOR + across.max(end)
}

/// The most cells `make-site` writes: what a terrain keeps whole
/// ([`shared::terrain::dem::MAX_DEM_CELLS`]); a finer site could only be loaded cropped or
/// decimated, and would be built in memory first (about 40 bytes a cell with its text).
pub const MAX_SITE_CELLS: u64 = shared::terrain::dem::MAX_DEM_CELLS;

/// Bytes a cell takes while the site is built and written: its elevation (16) and its text
/// (up to about 24).
const BYTES_PER_CELL: f64 = 40.0;

/// Columns and rows of the site on a grid of spacing `cell`.
fn size(cell: f64) -> (f64, f64) {
    let n = |extent: f64| (extent / cell).round() + 1.0;
    (n(LENGTH), n(WIDTH))
}

/// The site on a grid of spacing `cell`, its cell centres from (0, 0) to (LENGTH, WIDTH).
pub fn grid(cell: f64) -> Grid {
    let (nx, ny) = size(cell);
    Grid::from_fn(nx as usize, ny as usize, 0.0, 0.0, cell, elevation)
}

/// Refuses a spacing whose grid is past [`MAX_SITE_CELLS`], before anything is built: the
/// estimate of cells, triangles and bytes, and the finest spacing that fits.
fn check_size(cell: f64) -> Result<(), String> {
    let (nx, ny) = size(cell);
    let cells = nx * ny;
    if cells <= MAX_SITE_CELLS as f64 {
        return Ok(());
    }
    // (L/c + 1)(W/c + 1) ≤ N: the finest spacing that fits, rounded up to 2 digits.
    let mut finest = (LENGTH * WIDTH / MAX_SITE_CELLS as f64).sqrt();
    while size(finest).0 * size(finest).1 > MAX_SITE_CELLS as f64 {
        finest *= 1.01;
    }
    let digits = 10f64.powf(finest.log10().floor() - 1.0);
    let finest = (finest / digits).ceil() * digits;
    Err(format!(
        "--cell {}: the site would be {} × {} = {cells:.3e} cells ({:.3e} triangles, about {:.1e} bytes to build and write), past the limit of {MAX_SITE_CELLS} cells (MAX_SITE_CELLS: what a terrain keeps whole); fix: give --cell {finest} or coarser",
        readable(cell),
        readable(nx),
        readable(ny),
        2.0 * (nx - 1.0) * (ny - 1.0),
        cells * BYTES_PER_CELL
    ))
}

#[derive(Debug, Args)]
pub struct SiteArgs {
    /// The .asc file to write.
    #[arg(long, default_value = "scenes/fjord/fjord.asc")]
    pub out: PathBuf,
    /// Grid spacing [m] (the scene's file uses 4 m).
    #[arg(long, allow_hyphen_values = true, default_value_t = SCENE_CELL)]
    pub cell: f64,
}

/// Writes the grid; the exit code.
pub fn run(args: SiteArgs) -> u8 {
    if !(args.cell.is_finite() && args.cell > 0.0 && args.cell <= 0.5 * WIDTH) {
        eprintln!(
            "coupler: error: --cell {}: give a grid spacing in metres, in (0, {}]",
            readable(args.cell),
            0.5 * WIDTH
        );
        return 1;
    }
    if let Err(e) = check_size(args.cell) {
        eprintln!("coupler: error: {e}");
        return 1;
    }
    let g = grid(args.cell);
    if let Some(dir) = args.out.parent().filter(|d| !d.as_os_str().is_empty())
        && let Err(e) = std::fs::create_dir_all(dir)
    {
        eprintln!("coupler: error: cannot create {}: {e}", dir.display());
        return 1;
    }
    match std::fs::write(&args.out, g.to_asc()) {
        Ok(()) => {
            println!(
                "wrote {} ({} × {} cells of {} m, {} triangles)",
                args.out.display(),
                g.ncols,
                g.nrows,
                args.cell,
                2 * (g.ncols - 1) * (g.nrows - 1)
            );
            0
        }
        Err(e) => {
            eprintln!("coupler: error: cannot write {}: {e}", args.out.display());
            1
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The committed grid is what this file makes (regenerate it with `coupler make-site`).
    #[test]
    fn the_scene_grid_is_the_generated_one() {
        let path =
            std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("../scenes/fjord/fjord.asc");
        let committed = std::fs::read_to_string(&path).expect("scenes/fjord/fjord.asc");
        assert!(
            committed == grid(SCENE_CELL).to_asc(),
            "scenes/fjord/fjord.asc is stale: run `coupler make-site`"
        );
    }

    /// `--cell 1e-3` would ask for 10¹¹ cells (terabytes): refused before anything is built,
    /// with the estimate and the finest spacing that fits, which itself passes.
    #[test]
    fn a_site_past_the_cell_limit_is_refused_with_the_finest_spacing() {
        let e = check_size(1e-3).unwrap_err();
        assert!(
            e.contains("--cell 0.001")
                && e.contains("MAX_SITE_CELLS")
                && e.contains("1.040e11 cells")
                && e.contains("fix: give --cell"),
            "{e}"
        );
        let finest: f64 = e
            .split("fix: give --cell ")
            .nth(1)
            .and_then(|s| s.split_whitespace().next())
            .unwrap()
            .parse()
            .unwrap();
        assert!(check_size(finest).is_ok(), "{finest}");
        assert!(check_size(SCENE_CELL).is_ok());
    }

    #[test]
    fn flanks_and_ends_hold_the_water() {
        assert_eq!(elevation(200.0, 120.0), FLOOR);
        assert!((elevation(200.0, 0.0) - (FLOOR + 100.0 * 35f64.to_radians().tan())).abs() < 1e-9);
        // Every edge of the site is above the still water (z = 0).
        for k in 0..=40 {
            let (x, y) = (LENGTH * k as f64 / 40.0, WIDTH * k as f64 / 40.0);
            for (px, py) in [(x, 0.0), (x, WIDTH), (0.0, y), (LENGTH, y)] {
                assert!(
                    elevation(px, py) > 5.0,
                    "({px}, {py}): {}",
                    elevation(px, py)
                );
            }
        }
    }
}
