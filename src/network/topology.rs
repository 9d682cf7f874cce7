//! Connectivity topology (PAPERS.md §3.2, the paper's table 2): for each
//! section's start and end node, the sections connected there and their count;
//! directed successors honouring one-way roads; weakly and strongly connected
//! components (crate `petgraph`).

use super::model::{NodeId, RoadNetwork, SectionId};
use petgraph::algo::{connected_components, kosaraju_scc};
use petgraph::graph::{DiGraph, NodeIndex};

/// Which end of a section meets a node.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum SectionEnd {
    /// The section's start node.
    Start,
    /// The section's end node.
    End,
}

/// A section met at a node, and which of its ends is there.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct Incidence {
    /// The section.
    pub section: SectionId,
    /// Its end at the node.
    pub end: SectionEnd,
}

/// A section travelled in one direction.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash, PartialOrd, Ord)]
pub struct DirectedSection {
    /// The section.
    pub section: SectionId,
    /// `true` in the digitised direction (start to end).
    pub forward: bool,
}

/// Node–section incidence, directed successors and components.
#[derive(Debug, Clone)]
pub struct Topology {
    offsets: Vec<u32>,
    incidences: Vec<Incidence>,
    /// Strongly connected component of each node.
    node_scc: Vec<u32>,
    /// Number of weakly connected components.
    pub weak_components: usize,
    /// Number of strongly connected components (directed travel).
    pub strong_components: usize,
    /// The strongly connected component with the most road length.
    pub largest_scc: u32,
    /// Nodes reachable by directed travel from the largest strongly connected component.
    reachable: Vec<bool>,
}

impl Topology {
    /// Builds the topology of a network.
    pub fn build(net: &RoadNetwork) -> Self {
        let nn = net.nodes.len();
        let mut offsets = vec![0u32; nn + 1];
        for s in &net.sections {
            offsets[s.start as usize + 1] += 1;
            offsets[s.end as usize + 1] += 1;
        }
        for i in 1..offsets.len() {
            offsets[i] += offsets[i - 1];
        }
        let mut fill = offsets.clone();
        let mut incidences = vec![
            Incidence {
                section: 0,
                end: SectionEnd::Start
            };
            offsets[nn] as usize
        ];
        for (id, s) in net.sections.iter().enumerate() {
            for (node, end) in [(s.start, SectionEnd::Start), (s.end, SectionEnd::End)] {
                incidences[fill[node as usize] as usize] = Incidence {
                    section: id as SectionId,
                    end,
                };
                fill[node as usize] += 1;
            }
        }

        // Directed node graph: an edge per permitted direction of each section.
        let mut g: DiGraph<(), (), u32> = DiGraph::with_capacity(nn, net.sections.len() * 2);
        for _ in 0..nn {
            g.add_node(());
        }
        for s in &net.sections {
            if s.oneway.allows_forward() {
                g.add_edge(
                    NodeIndex::new(s.start as usize),
                    NodeIndex::new(s.end as usize),
                    (),
                );
            }
            if s.oneway.allows_backward() {
                g.add_edge(
                    NodeIndex::new(s.end as usize),
                    NodeIndex::new(s.start as usize),
                    (),
                );
            }
        }
        let weak_components = connected_components(&g);
        // Kosaraju with petgraph's iterative depth-first search: no recursion, so
        // million-node networks do not overflow the stack.
        let sccs = kosaraju_scc(&g);
        let mut node_scc = vec![0u32; nn];
        for (i, comp) in sccs.iter().enumerate() {
            for v in comp {
                node_scc[v.index()] = i as u32;
            }
        }
        // Largest by length of sections lying inside one component.
        let mut scc_len = vec![0.0f64; sccs.len()];
        for s in &net.sections {
            let (a, b) = (node_scc[s.start as usize], node_scc[s.end as usize]);
            if a == b {
                scc_len[a as usize] += s.length_m;
            }
        }
        let largest_scc = scc_len
            .iter()
            .enumerate()
            .max_by(|a, b| a.1.total_cmp(b.1))
            .map(|(i, _)| i as u32)
            .unwrap_or(0);

        // Breadth-first search from the largest component along permitted directions.
        let mut reachable = vec![false; nn];
        let mut queue: Vec<usize> = Vec::new();
        for (v, &c) in node_scc.iter().enumerate() {
            if c == largest_scc {
                reachable[v] = true;
                queue.push(v);
            }
        }
        while let Some(v) = queue.pop() {
            for w in g.neighbors(NodeIndex::new(v)) {
                if !reachable[w.index()] {
                    reachable[w.index()] = true;
                    queue.push(w.index());
                }
            }
        }

        Self {
            offsets,
            incidences,
            node_scc,
            weak_components,
            strong_components: sccs.len(),
            largest_scc,
            reachable,
        }
    }

    /// Sections meeting at `node` (a loop section appears twice).
    pub fn incidences(&self, node: NodeId) -> &[Incidence] {
        &self.incidences
            [self.offsets[node as usize] as usize..self.offsets[node as usize + 1] as usize]
    }

    /// Number of section ends at `node` (a node's degree).
    pub fn degree(&self, node: NodeId) -> usize {
        (self.offsets[node as usize + 1] - self.offsets[node as usize]) as usize
    }

    /// The paper's table 2, one end of a section: the other sections connected at
    /// that end's node (the section itself excluded; the count is the length).
    pub fn connected_at(
        &self,
        net: &RoadNetwork,
        section: SectionId,
        end: SectionEnd,
    ) -> Vec<SectionId> {
        let s = &net.sections[section as usize];
        let node = match end {
            SectionEnd::Start => s.start,
            SectionEnd::End => s.end,
        };
        let mut out: Vec<SectionId> = self
            .incidences(node)
            .iter()
            .map(|i| i.section)
            .filter(|&o| o != section)
            .collect();
        out.sort_unstable();
        out.dedup();
        out
    }

    /// The node where a directed traversal arrives.
    pub fn arrival_node(&self, net: &RoadNetwork, d: DirectedSection) -> NodeId {
        let s = &net.sections[d.section as usize];
        if d.forward {
            s.end
        } else {
            s.start
        }
    }

    /// Directed sections a vehicle may take after travelling `d`, honouring
    /// one-way roads (turning back onto the same two-way section included).
    pub fn successors(&self, net: &RoadNetwork, d: DirectedSection) -> Vec<DirectedSection> {
        let node = self.arrival_node(net, d);
        self.departures(net, node).collect()
    }

    /// Directed sections that may be entered at `node`.
    pub fn departures<'a>(
        &'a self,
        net: &'a RoadNetwork,
        node: NodeId,
    ) -> impl Iterator<Item = DirectedSection> + 'a {
        self.incidences(node).iter().filter_map(move |i| {
            let s = &net.sections[i.section as usize];
            match i.end {
                SectionEnd::Start if s.oneway.allows_forward() => Some(DirectedSection {
                    section: i.section,
                    forward: true,
                }),
                SectionEnd::End if s.oneway.allows_backward() => Some(DirectedSection {
                    section: i.section,
                    forward: false,
                }),
                _ => None,
            }
        })
    }

    /// Strongly connected component of `node`.
    pub fn scc_of(&self, node: NodeId) -> u32 {
        self.node_scc[node as usize]
    }

    /// Can a vehicle starting in the largest strongly connected component drive
    /// onto this section in some permitted direction?
    pub fn reachable_from_largest(&self, net: &RoadNetwork, section: SectionId) -> bool {
        let s = &net.sections[section as usize];
        (s.oneway.allows_forward() && self.reachable[s.start as usize])
            || (s.oneway.allows_backward() && self.reachable[s.end as usize])
    }

    /// Share of road length (0..=1) whose both ends lie in the largest strongly
    /// connected component.
    pub fn largest_scc_length_share(&self, net: &RoadNetwork) -> f64 {
        let total = net.length_m();
        if total <= 0.0 {
            return 0.0;
        }
        let inside: f64 = net
            .sections
            .iter()
            .filter(|s| {
                self.node_scc[s.start as usize] == self.largest_scc
                    && self.node_scc[s.end as usize] == self.largest_scc
            })
            .map(|s| s.length_m)
            .sum();
        inside / total
    }
}
