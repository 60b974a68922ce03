//! What `coupler check` says about a scene's `[[slide]]`s: the blocks their joint sets cut
//! (count, smallest / mean / largest volume, the slivers dropped) and, on request, the blocks
//! as a VTK file to inspect before the run (`coupler check SCENE --slides-vtk FILE`).

use shared::geometry::Polyhedron;
use shared::scene::Scene;
use std::path::Path;

/// Draws a progress bar on stderr (a terminal only) while a slide's cutting takes more than a
/// second ([`shared::scene::slide::report_cutting_progress`]); set once when the coupler starts.
pub fn show_cutting_progress() {
    use indicatif::{ProgressBar, ProgressDrawTarget, ProgressStyle};
    static BAR: std::sync::Mutex<Option<ProgressBar>> = std::sync::Mutex::new(None);
    shared::scene::slide::report_cutting_progress(Box::new(|p| {
        let Ok(mut bar) = BAR.lock() else { return };
        if p.done {
            if let Some(b) = bar.take() {
                b.finish_and_clear();
            }
            return;
        }
        let b = bar.get_or_insert_with(|| {
            let b = ProgressBar::with_draw_target(
                Some(p.expected as u64),
                ProgressDrawTarget::stderr(),
            );
            b.set_style(
                ProgressStyle::with_template("{bar:30} {pos}/{len} blocks, {msg} ({elapsed})")
                    .expect("valid template")
                    .progress_chars("=> "),
            );
            b
        });
        b.set_message(format!(
            "cutting slide '{}', joint set {}/{}",
            p.slide, p.set, p.sets
        ));
        b.set_position(p.pieces as u64);
    }));
}

/// One line per slide.
pub fn describe(scene: &Scene) -> Vec<String> {
    scene
        .slides
        .iter()
        .zip(&scene.slide_cuts)
        .map(|(s, cut)| format!("slide '{}': {cut}", s.name))
        .collect()
}

/// Writes every block cut from a slide to `path` (VTK PolyData, `.vtp`) with, per block, the
/// slide's index, the block's index within it and its volume [m³] as cell data. The file is
/// written beside `path` and renamed over it, so a `path` that is not a regular file (a device
/// such as /dev/full, a pipe, a directory) is refused before anything is written: the rename
/// would replace it, and report success.
pub fn write_vtk(scene: &Scene, path: &Path) -> Result<usize, String> {
    if let Ok(meta) = std::fs::metadata(path)
        && !meta.is_file()
    {
        return Err(format!(
            "cannot write {}: not a regular file (a device, a pipe or a directory); the blocks \
             are written beside it and renamed over it, which would replace it. Fix: name a \
             .vtp file, e.g. --slides-vtk blocks.vtp",
            path.display()
        ));
    }
    let mut corners: Vec<Vec<[f64; 3]>> = Vec::new();
    let mut faces: Vec<Vec<Vec<u32>>> = Vec::new();
    let (mut slide, mut index, mut volume) = (Vec::new(), Vec::new(), Vec::new());
    for (si, cut) in scene.slide_cuts.iter().enumerate() {
        for k in 0..cut.blocks {
            let b = &scene.blocks[cut.first_block + k];
            let p =
                Polyhedron::from_shape(&b.shape).map_err(|e| format!("block '{}': {e}", b.name))?;
            corners.push(
                p.vertices
                    .iter()
                    .map(|v| (v.coords + p.centroid.coords).into())
                    .collect(),
            );
            faces.push(p.faces.iter().map(|f| f.vertices.clone()).collect());
            slide.push(si as f64);
            index.push(k as f64);
            volume.push(p.volume);
        }
    }
    let refs: Vec<shared::vtk::PolyhedronRef<'_>> = corners
        .iter()
        .zip(&faces)
        .map(|(c, f)| (c.as_slice(), f.as_slice()))
        .collect();
    shared::vtk::write_polyhedra(
        path,
        &refs,
        &[("slide", &slide), ("block", &index), ("volume", &volume)],
        scene.output.vtk_format,
    )
    .map_err(|e| format!("cannot write {}: {e}", path.display()))?;
    Ok(refs.len())
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_cut_blocks_are_written_and_read_back() {
        let text = "name = \"s\"\n[time]\nend = 0.1\n[domain]\nmin = [-5, -5, -5]\nmax = [5, 5, 5]\n\
            [[slide]]\nname = \"r\"\nregion = { type = \"box\", min = [0, 0, 0], max = [2, 2, 1] }\n\
            [[slide.joint_set]]\ndip = 90\ndip_direction = 90\nspacing = 1\n\
            [[slide.joint_set]]\ndip = 90\ndip_direction = 0\nspacing = 1\n";
        let scene = Scene::parse(text, "t").unwrap();
        let lines = describe(&scene);
        assert!(lines[0].starts_with("slide 'r': 4 blocks"), "{lines:?}");
        let dir = std::env::temp_dir().join(format!("rockwave-slides-{}", std::process::id()));
        std::fs::create_dir_all(&dir).unwrap();
        let path = dir.join("slides.vtp");
        assert_eq!(write_vtk(&scene, &path).unwrap(), 4);
        let vtp = shared::vtk::read_vtp(&path).unwrap();
        let vol = vtp.array("CellData", "volume").unwrap().values.to_f64();
        // 6 faces per block, each carrying its block's volume: 4 unit columns of 1 m³.
        assert_eq!(vol.len(), 24);
        assert!(vol.iter().all(|v| (v - 1.0).abs() < 1e-12), "{vol:?}");
        std::fs::remove_dir_all(&dir).unwrap();
    }

    #[test]
    fn a_device_or_a_directory_is_refused_and_write_errors_are_named() {
        let text = "name = \"s\"\n[time]\nend = 0.1\n[domain]\nmin = [-5, -5, -5]\nmax = [5, 5, 5]\n\
            [[slide]]\nname = \"r\"\nregion = { type = \"box\", min = [0, 0, 0], max = [2, 2, 1] }\n\
            [[slide.joint_set]]\ndip = 90\ndip_direction = 90\nspacing = 1\n";
        let scene = Scene::parse(text, "t").unwrap();
        let dir = tempfile::tempdir().unwrap();
        for path in [Path::new("/dev/full"), dir.path()] {
            let msg = write_vtk(&scene, path).unwrap_err();
            assert!(
                msg.contains(&path.display().to_string())
                    && msg.contains("not a regular file")
                    && msg.contains("Fix:"),
                "{msg}"
            );
        }
        let missing = dir.path().join("no/such/dir/blocks.vtp");
        let msg = write_vtk(&scene, &missing).unwrap_err();
        assert!(
            msg.contains("blocks.vtp") && msg.contains("os error"),
            "{msg}"
        );
    }
}
