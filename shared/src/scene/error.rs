//! A scene's field errors: which field (its path, and the line it sits on), the bad value, the
//! problem and the fix.

/// One step of a field path: a table key or an array index.
#[derive(Debug, Clone, PartialEq)]
pub enum Seg {
    Key(String),
    Index(usize),
}

/// One invalid field.
#[derive(Debug, Clone)]
pub struct FieldError {
    /// Dotted path as written in the TOML, e.g. `block[2].density`.
    pub path: String,
    pub(crate) segments: Vec<Seg>,
    /// The offending value as written.
    pub value: String,
    /// What is wrong with it.
    pub problem: String,
    /// What to write instead.
    pub fix: String,
    /// 1-based line in the scene text, where it could be found.
    pub line: Option<usize>,
}

impl FieldError {
    /// An error at the field `path` (table keys from the root, e.g. `["fluid", "wcsph", "gamma"]`).
    pub fn new(path: &[&str], value: String, problem: &str, fix: &str) -> Self {
        Self {
            path: path.join("."),
            segments: path.iter().map(|k| Seg::Key((*k).into())).collect(),
            value,
            problem: problem.into(),
            fix: fix.into(),
            line: None,
        }
    }
}

impl std::fmt::Display for FieldError {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        if let Some(l) = self.line {
            write!(f, "line {l}: ")?;
        }
        write!(
            f,
            "{} = {}: {}; fix: {}",
            self.path, self.value, self.problem, self.fix
        )
    }
}

/// `block[2].shape.min` from its segments.
pub(crate) fn render_path(segments: &[Seg]) -> String {
    let mut path = String::new();
    for s in segments {
        match s {
            Seg::Key(k) if path.is_empty() => path.push_str(k),
            Seg::Key(k) => {
                path.push('.');
                path.push_str(k)
            }
            Seg::Index(i) => path.push_str(&format!("[{i}]")),
        }
    }
    path
}
