//! Graphs of curve edges: the split of a graph into arcs between extraordinary nodes (valence
//! other than two) or closed loops of regular nodes (thesis Def. 2.1). Used by the ridge tracer
//! and by the pruning of sharp-edge graphs.

/// One arc of the graph: a walk between extraordinary nodes (valence ≠ 2), or a closed loop of
/// regular nodes (first node not repeated).
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct Arc {
    pub nodes: Vec<u32>,
    /// Indices of the graph edges it uses, in order.
    pub edges: Vec<u32>,
    pub closed: bool,
}

/// The edges with `alive[e]` at each node, in edge order, as compressed rows: node n's are
/// `inc[offsets[n]..offsets[n + 1]]`. An edge from a node to itself is listed twice there.
pub fn incidence(n_nodes: usize, edges: &[[u32; 2]], alive: &[bool]) -> (Vec<usize>, Vec<u32>) {
    let mut offsets = vec![0usize; n_nodes + 1];
    for (e, &[p, q]) in edges.iter().enumerate() {
        if alive[e] {
            offsets[p as usize + 1] += 1;
            offsets[q as usize + 1] += 1;
        }
    }
    for i in 0..n_nodes {
        offsets[i + 1] += offsets[i];
    }
    let mut fill = offsets.clone();
    let mut inc = vec![0u32; offsets[n_nodes]];
    for (e, &[p, q]) in edges.iter().enumerate() {
        if alive[e] {
            for n in [p, q] {
                inc[fill[n as usize]] = e as u32;
                fill[n as usize] += 1;
            }
        }
    }
    (offsets, inc)
}

/// Splits the edges with `alive[e]` into arcs (Def. 2.1). Arcs start at extraordinary nodes in
/// node order, leaving through their edges in edge order; loops follow, from their smallest
/// node. Every live edge belongs to exactly one arc.
pub fn extract_arcs(n_nodes: usize, edges: &[[u32; 2]], alive: &[bool]) -> Vec<Arc> {
    let (offsets, inc) = incidence(n_nodes, edges, alive);
    let valence = |n: usize| offsets[n + 1] - offsets[n];
    let other = |e: u32, n: u32| {
        let [p, q] = edges[e as usize];
        if p == n {
            q
        } else {
            p
        }
    };
    let mut used = vec![false; edges.len()];
    let mut arcs = Vec::new();
    // Walks from `start` through `first`, continuing through regular nodes.
    let walk = |start: u32, first: u32, used: &mut Vec<bool>| -> Arc {
        let mut nodes = vec![start];
        let mut path = vec![first];
        used[first as usize] = true;
        let mut cur = other(first, start);
        loop {
            nodes.push(cur);
            if valence(cur as usize) != 2 {
                break;
            }
            let next = inc[offsets[cur as usize]..offsets[cur as usize + 1]]
                .iter()
                .copied()
                .find(|&e| !used[e as usize]);
            match next {
                Some(e) => {
                    used[e as usize] = true;
                    path.push(e);
                    cur = other(e, cur);
                }
                None => break,
            }
        }
        Arc {
            nodes,
            edges: path,
            closed: false,
        }
    };
    for n in 0..n_nodes {
        if valence(n) == 2 || valence(n) == 0 {
            continue;
        }
        for &e in &inc[offsets[n]..offsets[n + 1]] {
            if !used[e as usize] {
                arcs.push(walk(n as u32, e, &mut used));
            }
        }
    }
    // What is left are loops through regular nodes only.
    for n in 0..n_nodes {
        if let Some(&e) = inc[offsets[n]..offsets[n + 1]]
            .iter()
            .find(|&&e| !used[e as usize])
        {
            let mut arc = walk(n as u32, e, &mut used);
            // The walk ends where it started: drop the repeated node.
            if arc.nodes.len() > 1 && arc.nodes.first() == arc.nodes.last() {
                arc.nodes.pop();
            }
            arc.closed = true;
            arcs.push(arc);
        }
    }
    arcs
}
