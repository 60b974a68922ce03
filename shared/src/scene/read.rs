//! Reading a scene file from the outside world: only a regular file of at most
//! [`MAX_SCENE_BYTES`] is read (a device such as `/dev/zero` would be read until memory runs
//! out, a FIFO would block for ever), and a value of the wrong type is explained in words with
//! an example ([`type_fix`]), not only with the parser's type name.

use super::SceneError;
use std::io::Read;
use std::path::Path;

/// Largest scene file read [bytes]. A scene is a few kB of TOML (the repository's largest is
/// under 5 kB); 1 MiB leaves room for hand-written convex blocks of many vertices, while
/// ground of many triangles belongs in a `[[terrain]]` file. Bounds what a wrong path (a log,
/// a mesh, a device) can make the parser hold.
pub const MAX_SCENE_BYTES: u64 = 1 << 20;

/// The text of the scene file at `path`, refused before any read when it is not a regular
/// file or is longer than [`MAX_SCENE_BYTES`]; the read itself is bounded too (a file that
/// grows while read).
pub(super) fn scene_text(path: &Path) -> Result<String, SceneError> {
    let shown = path.display().to_string();
    let read_error = |source| SceneError::Read {
        path: shown.clone(),
        source,
    };
    let too_long = |len: u64| SceneError::NotAScene {
        path: shown.clone(),
        problem: format!(
            "holds {len} bytes or more, more than a scene may hold ({MAX_SCENE_BYTES} bytes: a \
             scene is a few kB of TOML)"
        ),
        fix: "name the scene's .toml file; ground of many triangles goes in a [[terrain]] file \
              the scene names"
            .into(),
    };
    let meta = std::fs::metadata(path).map_err(read_error)?;
    if !meta.is_file() {
        return Err(SceneError::NotAScene {
            path: shown.clone(),
            problem: "is not a regular file (a directory, a device or a pipe), whose reading \
                      could block for ever or never end"
                .into(),
            fix: "name the scene's .toml file itself".into(),
        });
    }
    if meta.len() > MAX_SCENE_BYTES {
        return Err(too_long(meta.len()));
    }
    let mut bytes = Vec::with_capacity(meta.len() as usize);
    std::fs::File::open(path)
        .and_then(|f| f.take(MAX_SCENE_BYTES + 1).read_to_end(&mut bytes))
        .map_err(read_error)?;
    if bytes.len() as u64 > MAX_SCENE_BYTES {
        return Err(too_long(bytes.len() as u64));
    }
    String::from_utf8(bytes).map_err(|e| {
        read_error(std::io::Error::new(
            std::io::ErrorKind::InvalidData,
            format!(
                "not UTF-8 text (byte {} is not part of a character): a scene is a TOML text file",
                e.utf8_error().valid_up_to()
            ),
        ))
    })
}

/// For a parser message about a value of the wrong type at `field` (serde's "invalid type:
/// floating point `2.5`, expected usize" or "invalid value: integer `-5`, expected u32"), a
/// line saying what the field takes, in words, what was found, and an example; `None` for any
/// other message.
pub(super) fn type_fix(field: &str, message: &str) -> Option<String> {
    let rest = message
        .strip_prefix("invalid type: ")
        .or_else(|| message.strip_prefix("invalid value: "))?;
    let (found, expected) = rest.rsplit_once(", expected ")?;
    let expected = expected.trim();
    let (words, example) = match expected {
        // The field's own range (solid_substeps 1..=10 000, …) is its validation's to name.
        "usize" | "u64" | "u32" => ("a whole number >= 0, without sign or decimal point", "10"),
        "u16" => ("a whole number from 0 to 65535", "10"),
        "u8" => ("a whole number from 0 to 255", "10"),
        "i64" | "i32" => ("a whole number, without decimal point", "10"),
        "f64" | "f32" => ("a number", "1.0"),
        "a boolean" => ("true or false", "true"),
        "a string" => ("a text in double quotes", "\"text\""),
        "path string" => ("a file path in double quotes", "\"ground.asc\""),
        e if e.starts_with("an array") || e.starts_with("a sequence") => {
            ("an array in brackets", "[0.0, 0.0, 0.0]")
        }
        _ => return None,
    };
    let key = field
        .rsplit('.')
        .next()
        .unwrap_or(field)
        .split('[')
        .next()
        .unwrap_or(field);
    let example = match key {
        "max_blocks" => "10000",
        "solid_substeps" => "4",
        "name" => "\"wedge\"",
        "file" => "\"dem.asc\"",
        _ => example,
    };
    Some(format!(
        "\nfix: `{field}` takes {words} (found {found}), e.g. {key} = {example}"
    ))
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::scene::{DEFAULT_SCENE, Scene};

    fn error_of(path: &Path) -> String {
        Scene::load(path).unwrap_err().to_string()
    }

    #[test]
    fn a_device_a_directory_and_a_pipe_are_refused_before_any_read() {
        for p in ["/dev/zero", "/tmp"] {
            let msg = error_of(Path::new(p));
            assert!(
                msg.contains(p) && msg.contains("not a regular file") && msg.contains("fix:"),
                "{msg}"
            );
        }
        let dir = tempfile::tempdir().unwrap();
        let fifo = dir.path().join("scene.toml");
        let made = std::process::Command::new("mkfifo").arg(&fifo).status();
        if made.is_ok_and(|s| s.success()) {
            assert!(error_of(&fifo).contains("not a regular file"));
        }
    }

    #[test]
    fn a_file_longer_than_a_scene_is_refused_with_the_limit() {
        let dir = tempfile::tempdir().unwrap();
        let path = dir.path().join("big.toml");
        let f = std::fs::File::create(&path).unwrap();
        f.set_len(MAX_SCENE_BYTES + 1).unwrap(); // sparse: nothing written
        let msg = error_of(&path);
        assert!(
            msg.contains(&format!("{MAX_SCENE_BYTES} bytes")) && msg.contains("fix:"),
            "{msg}"
        );
    }

    #[test]
    fn a_binary_file_is_named_as_not_text() {
        let dir = tempfile::tempdir().unwrap();
        let path = dir.path().join("s.toml");
        std::fs::write(&path, [b'a', 0xff, 0xfe]).unwrap();
        let msg = error_of(&path);
        assert!(msg.contains("not UTF-8") && msg.contains("s.toml"), "{msg}");
    }

    #[test]
    fn wrong_types_name_the_field_the_type_and_an_example() {
        let slide = "\n[[slide]]\nname = \"r\"\nregion = { type = \"box\", min = [0, 0, 0], max = [0.4, 0.4, 0.4] }\n\
                     max_blocks = MB\n[[slide.joint_set]]\ndip = 0\ndip_direction = 0\nspacing = 0.1\n";
        let cases = [
            (
                format!("{DEFAULT_SCENE}{}", slide.replace("MB", "-5")),
                "slide[0].max_blocks",
                "whole number >= 0",
                "max_blocks = 10000",
            ),
            (
                format!("{DEFAULT_SCENE}{}", slide.replace("MB", "2.5")),
                "slide[0].max_blocks",
                "found floating point `2.5`",
                "max_blocks = 10000",
            ),
            (
                DEFAULT_SCENE.replace("[coupling]\n", "[coupling]\nsolid_substeps = -2\n"),
                "coupling.solid_substeps",
                "whole number >= 0, without sign",
                "solid_substeps = 4",
            ),
            (
                format!("{DEFAULT_SCENE}\n[[terrain]]\nfile = 5\n"),
                "terrain[0].file",
                "a file path in double quotes",
                "file = \"dem.asc\"",
            ),
            (
                DEFAULT_SCENE.replacen("end = ", "end = \"long\" #", 1),
                "time.end",
                "a number",
                "end = 1.0",
            ),
        ];
        for (text, field, words, example) in cases {
            let msg = Scene::parse(&text, "t.toml").unwrap_err().to_string();
            assert!(
                msg.contains(&format!("fix: `{field}` takes"))
                    && msg.contains(words)
                    && msg.contains(example)
                    && msg.contains("line "),
                "{msg}"
            );
        }
    }
}
