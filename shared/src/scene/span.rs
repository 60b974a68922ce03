//! Finds the line of a field in the scene text, so a validation error can point at it.

use super::validate::{FieldError, Seg};
use toml::de::{DeTable, DeValue};

/// Fills `line` of each error with the line of its field (or of the nearest enclosing table
/// when the field itself is absent, e.g. a missing `motion`).
pub(super) fn locate(text: &str, errors: &mut [FieldError]) {
    let Ok(root) = DeTable::parse(text) else {
        return;
    };
    for e in errors.iter_mut() {
        let mut span = root.span();
        let mut value: Option<&DeValue<'_>> = None;
        let mut table: Option<&DeTable<'_>> = Some(root.get_ref());
        for seg in &e.segments {
            let next = match (seg, table, value) {
                (Seg::Key(k), Some(t), _) => {
                    t.iter().find(|(key, _)| key.get_ref() == k).map(|(_, v)| v)
                }
                (Seg::Index(i), _, Some(DeValue::Array(a))) => a.get(*i),
                _ => None,
            };
            let Some(next) = next else { break };
            span = next.span();
            value = Some(next.get_ref());
            table = match next.get_ref() {
                DeValue::Table(t) => Some(t),
                _ => None,
            };
        }
        e.line = Some(text[..span.start.min(text.len())].matches('\n').count() + 1);
    }
}
