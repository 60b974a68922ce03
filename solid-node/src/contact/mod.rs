//! Blocks in contact, found and answered:
//!
//! - [`broad_phase`], [`narrow_phase`]: which pairs may touch, then their vertex–face and
//!   edge–edge contacts; [`terrain`]: blocks against the fixed `[[terrain]]` mesh (BVH queries);
//! - [`springs`]: the normal and shear contact springs (DDA's penalty springs, Shi 1993);
//! - [`friction`]: Mohr–Coulomb with cohesion, and the three contact states of the open–close
//!   logic;
//! - [`joints`]: the bonded joints between blocks cut from one `[[slide]]` (tension cut-off,
//!   residual friction once broken);
//! - here: a contact between two blocks: which features touch, the local geometry, and the state
//!   that persists from step to step (the shear spring and the Mohr–Coulomb state).
//!
//! Contacts are kept in one flat list sorted by [`ContactKey`], so the contacts of the previous
//! step are found by binary search (no hashing, no allocation in the step loop).

pub mod broad_phase;
pub mod friction;
pub mod joints;
pub mod narrow_phase;
pub mod springs;
pub mod terrain;

use friction::{ContactState, Joint};
use shared::math::{Point, Real, Vector};

/// What touches what. For the pair (a, b) with a < b:
/// - [`Feature::VertexOfA`]: vertex `i` of a against a face of b;
/// - [`Feature::VertexOfB`]: vertex `i` of b against a face of a;
/// - [`Feature::EdgeEdge`]: edge `i` of a crossing edge `j` of b.
#[derive(
    Debug, Clone, Copy, PartialEq, Eq, PartialOrd, Ord, Hash, serde::Serialize, serde::Deserialize,
)]
pub enum Feature {
    VertexOfA,
    VertexOfB,
    EdgeEdge,
}

/// Identifies a contact across steps.
#[derive(
    Debug, Clone, Copy, PartialEq, Eq, PartialOrd, Ord, Hash, serde::Serialize, serde::Deserialize,
)]
pub struct ContactKey {
    pub a: u32,
    pub b: u32,
    pub feature: Feature,
    pub i: u32,
    pub j: u32,
}

/// One vertex–face or edge–edge contact.
#[derive(Debug, Clone, Copy, serde::Serialize, serde::Deserialize)]
pub struct Contact {
    pub key: ContactKey,
    /// Block owning the vertex (or edge i): the force [`Contact::force`] acts on it.
    pub p: u32,
    /// Block owning the face (or edge j): it receives the opposite force.
    pub q: u32,
    /// Face of `q` for a vertex–face contact (kept while valid: DDA's reference face).
    pub face: u32,
    /// World contact point (the vertex, or the midpoint of the two closest edge points).
    pub point: Point,
    /// Unit normal, outward from `q`.
    pub normal: Vector,
    /// Signed normal distance [m]: negative when interpenetrating.
    pub gap: Real,
    /// Tributary area [m²] carrying cohesion (face–face contacts only).
    pub area: Real,
    /// tan φ of the pair.
    pub tan_phi: Real,
    /// Cohesion of the pair [Pa] (0 once a slide joint's bond is broken).
    pub cohesion: Real,
    /// Tensile strength [Pa] of a bonded slide joint; 0 otherwise.
    pub tensile: Real,
    /// Bonded across a slide's joint ([`crate::contact::joints`]): carries tension up to
    /// `tensile · bond_area` and shear up to the Mohr–Coulomb limit with cohesion; broken for
    /// good once either is exceeded.
    pub bonded: bool,
    /// This contact's share of the joint's area [m²], fixed when the bond is made.
    pub bond_area: Real,
    /// Shear spring elongation [m], tangential, world frame; zero when open.
    pub shear: Vector,
    pub state: ContactState,
    /// Normal force of the last committed state [N] (≥ 0).
    pub normal_force: Real,
    /// Total force on `p` [N] (the opposite acts on `q`), last committed.
    pub force: Vector,
}

impl Contact {
    /// A fresh contact (no history).
    pub fn new(key: ContactKey, p: u32, q: u32) -> Contact {
        Contact {
            key,
            p,
            q,
            face: u32::MAX,
            point: Point::origin(),
            normal: Vector::z(),
            gap: 0.0,
            area: 0.0,
            tan_phi: 0.0,
            cohesion: 0.0,
            tensile: 0.0,
            bonded: false,
            bond_area: 0.0,
            shear: Vector::zeros(),
            state: ContactState::Open,
            normal_force: 0.0,
            force: Vector::zeros(),
        }
    }

    /// Carries the history of the same contact from the previous step: state, forces and the
    /// shear spring turned into the new tangent plane with its length kept (the contact
    /// frame rotates with the blocks; the spring must not shrink because of it).
    pub fn inherit(&mut self, old: &Contact) {
        self.bonded = old.bonded;
        self.bond_area = old.bond_area;
        self.state = old.state;
        self.normal_force = old.normal_force;
        self.force = old.force;
        if old.state == ContactState::Open {
            self.shear = Vector::zeros();
            return;
        }
        let len = old.shear.norm();
        let t = old.shear - self.normal * self.normal.dot(&old.shear);
        let tl = t.norm();
        self.shear = if tl > 1e-14 * (1.0 + len) {
            t * (len / tl)
        } else {
            Vector::zeros()
        };
    }
}

impl Contact {
    /// Applies the pair's joint once the history is inherited: a contact found in the first
    /// detection (`at_start`) across a bonded joint is bonded; a bonded contact carries the
    /// joint's tension and its share of the joint's area; a broken (or never bonded) contact
    /// of a bonded pair keeps the residual friction only.
    #[inline]
    pub fn apply_joint(&mut self, joint: &Joint, fresh: bool, at_start: bool) {
        if fresh && at_start {
            self.bonded = joint.bonded;
        }
        if self.bonded {
            self.tensile = joint.tensile;
            self.area = self.bond_area;
        } else if joint.bonded {
            self.cohesion = 0.0;
            self.tensile = 0.0;
        }
    }

    /// Breaks a bond for good: residual friction only from now on.
    #[inline]
    pub fn break_bond(&mut self) {
        self.bonded = false;
        self.cohesion = 0.0;
        self.tensile = 0.0;
    }
}

/// The contacts of pair (a, b) within a list sorted by key.
pub fn pair_range(sorted: &[Contact], a: u32, b: u32) -> &[Contact] {
    let lo = sorted.partition_point(|c| (c.key.a, c.key.b) < (a, b));
    let hi = lo + sorted[lo..].partition_point(|c| (c.key.a, c.key.b) <= (a, b));
    &sorted[lo..hi]
}

/// The contact with this key in a list sorted by key.
pub fn find<'a>(sorted: &'a [Contact], key: &ContactKey) -> Option<&'a Contact> {
    sorted
        .binary_search_by(|c| c.key.cmp(key))
        .ok()
        .map(|i| &sorted[i])
}

/// Two unit tangents completing the contact normal `n` to a right-handed frame: the directions
/// of the shear springs.
pub fn tangents(n: &Vector) -> (Vector, Vector) {
    let t1 = n
        .cross(&if n.x.abs() < 0.9 {
            Vector::x()
        } else {
            Vector::y()
        })
        .normalize();
    (t1, n.cross(&t1))
}

/// Asserts that `contacts` are `n` contacts of `feature`, each along `normal` and `depth`
/// deep, both within `tol` (the narrow phases' unit tests).
#[cfg(test)]
pub(crate) fn assert_contacts(
    contacts: &[Contact],
    feature: Feature,
    n: usize,
    normal: Vector,
    depth: Real,
    tol: Real,
) {
    assert!(
        contacts.iter().all(|c| c.key.feature == feature),
        "not all {feature:?}: {contacts:#?}"
    );
    assert_eq!(contacts.len(), n, "{contacts:#?}");
    for c in contacts {
        assert!((c.normal - normal).norm() < tol, "normal {}", c.normal);
        assert!((c.gap + depth).abs() < tol, "gap {}", c.gap);
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn key(a: u32, b: u32, i: u32) -> ContactKey {
        ContactKey {
            a,
            b,
            feature: Feature::VertexOfA,
            i,
            j: 0,
        }
    }

    #[test]
    fn lookup_by_pair_and_key() {
        let list: Vec<Contact> = [(0, 1, 0), (0, 1, 3), (0, 2, 1), (1, 2, 0)]
            .iter()
            .map(|&(a, b, i)| Contact::new(key(a, b, i), a, b))
            .collect();
        assert_eq!(pair_range(&list, 0, 1).len(), 2);
        assert_eq!(pair_range(&list, 0, 2).len(), 1);
        assert_eq!(pair_range(&list, 3, 4).len(), 0);
        assert!(find(&list, &key(0, 1, 3)).is_some());
        assert!(find(&list, &key(0, 1, 2)).is_none());
    }

    #[test]
    fn inherited_shear_turns_with_the_normal() {
        let mut old = Contact::new(key(0, 1, 0), 0, 1);
        old.state = ContactState::Locked;
        old.shear = Vector::new(1e-4, 0.0, 0.0);
        let mut new = Contact::new(key(0, 1, 0), 0, 1);
        new.normal = Vector::new(0.1, 0.0, 1.0).normalize();
        new.inherit(&old);
        assert!(new.shear.dot(&new.normal).abs() < 1e-18);
        assert!((new.shear.norm() - 1e-4).abs() < 1e-16);
        old.state = ContactState::Open;
        new.inherit(&old);
        assert_eq!(new.shear, Vector::zeros());
    }
}
