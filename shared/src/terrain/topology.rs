//! What a terrain mesh's edges say about it: closed or open, manifold, consistently wound, and
//! whether its normals point into the ground.

/// The edge structure of a mesh.
#[derive(Debug, Clone, Default)]
pub struct Topology {
    /// Edges used by one triangle only (the rim of an open surface), as vertex pairs.
    pub rim: Vec<[u32; 2]>,
    /// An edge used by more than two triangles: (edge, how many).
    pub non_manifold: Option<([u32; 2], usize)>,
    /// Two triangles that share an edge but run along it the same way (one is wound the
    /// other way round): the two triangle indices.
    pub inconsistent: Option<(u32, u32)>,
    /// Number of edges wound inconsistently.
    pub inconsistent_count: usize,
}

impl Topology {
    /// True when every edge is shared by exactly two triangles.
    pub fn closed(&self) -> bool {
        self.rim.is_empty()
    }
}

/// The edges of `triangles`: sorted once (O(n log n)), no hashing, so the result is the same on
/// every run.
pub fn analyse(triangles: &[[u32; 3]]) -> Topology {
    // (low, high, forward, triangle) for each directed edge.
    let mut edges: Vec<(u32, u32, bool, u32)> = Vec::with_capacity(3 * triangles.len());
    for (t, tri) in triangles.iter().enumerate() {
        for k in 0..3 {
            let (a, b) = (tri[k], tri[(k + 1) % 3]);
            edges.push((a.min(b), a.max(b), a < b, t as u32));
        }
    }
    edges.sort_unstable();
    let mut topo = Topology::default();
    let mut i = 0;
    while i < edges.len() {
        let mut j = i + 1;
        while j < edges.len() && (edges[j].0, edges[j].1) == (edges[i].0, edges[i].1) {
            j += 1;
        }
        let edge = [edges[i].0, edges[i].1];
        match j - i {
            1 => topo.rim.push(edge),
            2 => {
                if edges[i].2 == edges[i + 1].2 {
                    topo.inconsistent_count += 1;
                    topo.inconsistent
                        .get_or_insert((edges[i].3, edges[i + 1].3));
                }
            }
            n => {
                topo.non_manifold.get_or_insert((edge, n));
            }
        }
        i = j;
    }
    topo
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_tetrahedron_is_closed_and_consistent() {
        let t = [[0, 2, 1], [0, 1, 3], [1, 2, 3], [0, 3, 2]];
        let topo = analyse(&t);
        assert!(topo.closed());
        assert!(topo.inconsistent.is_none() && topo.non_manifold.is_none());
        // One face turned over: its three edges each run the same way as a neighbour's.
        let mut bad = t;
        bad[2] = [1, 3, 2];
        let topo = analyse(&bad);
        assert_eq!(topo.inconsistent_count, 3);
        // Drop a face: three rim edges.
        assert_eq!(analyse(&t[..3]).rim.len(), 3);
    }
}
