//! Gmsh meshes (MSH 4.1, ASCII or binary) as [`nnm::model::Mesh`]: the second-order volume
//! elements (10-node tetrahedra, 27-node hexahedra) in nnm's node order, and the physical
//! groups as named node sets (docs/job-files.md, "Meshes").
//!
//! The `mshio` crate parses the sections it knows (`$Entities`, `$Nodes`, `$Elements`);
//! `$PhysicalNames`, which it skips, is a few ASCII lines read here.

use std::collections::{BTreeMap, HashMap};
use std::path::Path;

use mshio::mshfile::{ElementType, MshFile};
use nnm::model::{Mesh, MeshElement, MeshElementKind, NodeGroup};

use crate::error::{FileError, io_reason};

/// Gmsh's node order of its 10-node tetrahedron (type 11): the vertices, then the mid-edge
/// nodes of these edges.
const GMSH_TET10_EDGES: [[usize; 2]; 6] = [[0, 1], [1, 2], [0, 2], [0, 3], [2, 3], [1, 3]];

/// Gmsh's node order of its 27-node hexahedron (type 12) on `[−1, 1]³`: the vertices, the
/// twelve mid-edge nodes, the six face centres and the centre.
const GMSH_HEX27: [[f64; 3]; 27] = [
    [-1.0, -1.0, -1.0],
    [1.0, -1.0, -1.0],
    [1.0, 1.0, -1.0],
    [-1.0, 1.0, -1.0],
    [-1.0, -1.0, 1.0],
    [1.0, -1.0, 1.0],
    [1.0, 1.0, 1.0],
    [-1.0, 1.0, 1.0],
    [0.0, -1.0, -1.0],
    [-1.0, 0.0, -1.0],
    [-1.0, -1.0, 0.0],
    [1.0, 0.0, -1.0],
    [1.0, -1.0, 0.0],
    [0.0, 1.0, -1.0],
    [1.0, 1.0, 0.0],
    [-1.0, 1.0, 0.0],
    [0.0, -1.0, 1.0],
    [-1.0, 0.0, 1.0],
    [1.0, 0.0, 1.0],
    [0.0, 1.0, 1.0],
    [0.0, 0.0, -1.0],
    [0.0, -1.0, 0.0],
    [-1.0, 0.0, 0.0],
    [1.0, 0.0, 0.0],
    [0.0, 1.0, 0.0],
    [0.0, 0.0, 1.0],
    [0.0, 0.0, 0.0],
];

/// Reads the mesh of a Gmsh MSH 4.1 file: its tet10 and hex27 elements, its nodes in
/// ascending tag order, and its physical groups (of any dimension) as node groups.
/// One-line errors for an unreadable file, another MSH version, a file that does not parse,
/// and volume elements of another type.
pub fn read_mesh(path: &Path) -> Result<Mesh, FileError> {
    let fail = |message: String| FileError {
        path: path.to_owned(),
        message,
    };
    let bytes = std::fs::read(path).map_err(|e| fail(format!("cannot read: {}", io_reason(&e))))?;
    check_version(&bytes).map_err(fail)?;
    let names = physical_names(&bytes).map_err(fail)?;
    let msh = mshio::parse_msh_bytes(&bytes).map_err(|e| {
        fail(match e.first_msh_error() {
            Some(kind) => format!("not a valid MSH 4.1 file: {kind}"),
            None => "not a valid MSH 4.1 file".into(),
        })
    })?;
    mesh_of(&msh, &names).map_err(fail)
}

/// The version in `$MeshFormat`: only 4.1 is read (Gmsh writes 4.1 by default).
fn check_version(bytes: &[u8]) -> Result<(), String> {
    let text = String::from_utf8_lossy(&bytes[..bytes.len().min(256)]);
    let mut lines = text.lines().map(str::trim);
    if lines.next() != Some("$MeshFormat") {
        return Err("not a Gmsh mesh (no `$MeshFormat` on the first line)".into());
    }
    let version = lines
        .next()
        .and_then(|l| l.split_whitespace().next())
        .unwrap_or("");
    if version != "4.1" {
        return Err(format!(
            "MSH version {version}: nnm reads MSH 4.1 (Gmsh's default; `-format msh41`)"
        ));
    }
    Ok(())
}

/// `(dimension, tag) → name` of `$PhysicalNames` (ASCII in binary files too).
fn physical_names(bytes: &[u8]) -> Result<HashMap<(i32, i32), String>, String> {
    let mut names = HashMap::new();
    let Some(start) = find(bytes, b"$PhysicalNames") else {
        return Ok(names);
    };
    let rest = &bytes[start..];
    let end = find(rest, b"$EndPhysicalNames").ok_or("`$PhysicalNames` is not closed")?;
    let section = String::from_utf8_lossy(&rest[..end]);
    let bad = |line: &str| format!("bad `$PhysicalNames` line `{line}`");
    for line in section
        .lines()
        .skip(2)
        .map(str::trim)
        .filter(|l| !l.is_empty())
    {
        let mut words = line.splitn(3, char::is_whitespace);
        let dim = words
            .next()
            .and_then(|w| w.parse().ok())
            .ok_or_else(|| bad(line))?;
        let tag = words
            .next()
            .and_then(|w| w.parse().ok())
            .ok_or_else(|| bad(line))?;
        let name = words
            .next()
            .map(|w| w.trim().trim_matches('"'))
            .ok_or_else(|| bad(line))?;
        names.insert((dim, tag), name.to_string());
    }
    Ok(names)
}

fn find(haystack: &[u8], needle: &[u8]) -> Option<usize> {
    haystack.windows(needle.len()).position(|w| w == needle)
}

/// The mesh of a parsed file.
fn mesh_of(
    msh: &MshFile<u64, i32, f64>,
    names: &HashMap<(i32, i32), String>,
) -> Result<Mesh, String> {
    // Nodes by tag. mshio keeps the tags only when they are sparse; otherwise they run from
    // the smallest tag in the order of the blocks, as Gmsh writes them (a writer that lists
    // contiguous tags out of order is not read right: docs/job-files.md, "Meshes").
    let mut tagged: Vec<(u64, [f64; 3])> = Vec::new();
    if let Some(nodes) = &msh.data.nodes {
        let mut next = nodes.min_node_tag;
        for block in &nodes.node_blocks {
            let tags: Vec<u64> = match &block.node_tags {
                Some(map) => {
                    let mut t = vec![0; block.nodes.len()];
                    for (&tag, &k) in map {
                        t[k] = tag;
                    }
                    t
                }
                None => (next..next + block.nodes.len() as u64).collect(),
            };
            next += block.nodes.len() as u64;
            tagged.extend(
                tags.into_iter()
                    .zip(block.nodes.iter().map(|n| [n.x, n.y, n.z])),
            );
        }
    }
    tagged.sort_by_key(|(tag, _)| *tag);
    let index: HashMap<u64, usize> = tagged
        .iter()
        .enumerate()
        .map(|(k, (t, _))| (*t, k))
        .collect();
    let node = |tag: u64| {
        index.get(&tag).copied().ok_or_else(|| {
            format!("an element refers to node {tag}, which the file does not define")
        })
    };

    // The physical tags of each entity `(dim, tag)`.
    let mut physical: HashMap<(i32, i32), Vec<i32>> = HashMap::new();
    if let Some(entities) = &msh.data.entities {
        for p in &entities.points {
            physical.insert((0, p.tag), p.physical_tags.clone());
        }
        for c in &entities.curves {
            physical.insert((1, c.tag), c.physical_tags.clone());
        }
        for s in &entities.surfaces {
            physical.insert((2, s.tag), s.physical_tags.clone());
        }
        for v in &entities.volumes {
            physical.insert((3, v.tag), v.physical_tags.clone());
        }
    }

    let order = |kind: MeshElementKind, format: &[[f64; 3]]| {
        kind.order_in(format)
            .expect("Gmsh's element has every node of nnm's")
    };
    let tet10 = order(
        MeshElementKind::Tet10,
        &MeshElementKind::tet10_with_edges(&GMSH_TET10_EDGES),
    );
    let hex27 = order(MeshElementKind::Hex27, &GMSH_HEX27);
    let mut elements = Vec::new();
    let mut groups: HashMap<(i32, i32), Vec<usize>> = HashMap::new();
    for block in msh.data.elements.iter().flat_map(|e| &e.element_blocks) {
        let order = match block.element_type {
            ElementType::Tet10 => Some((MeshElementKind::Tet10, &tet10)),
            ElementType::Hex27 => Some((MeshElementKind::Hex27, &hex27)),
            other if block.entity_dim == 3 => {
                return Err(format!(
                    "volume {} has elements of type {other:?}: nnm takes 10-node tetrahedra and \
                     27-node hexahedra (Gmsh: Mesh.ElementOrder = 2, Mesh.SecondOrderIncomplete = 0)",
                    block.entity_tag
                ));
            }
            _ => None,
        };
        let entity_groups = physical
            .get(&(block.entity_dim, block.entity_tag))
            .map(Vec::as_slice)
            .unwrap_or(&[]);
        for element in &block.elements {
            let nodes = element
                .nodes
                .iter()
                .map(|&t| node(t))
                .collect::<Result<Vec<usize>, String>>()?;
            for &group in entity_groups {
                groups
                    .entry((block.entity_dim, group))
                    .or_default()
                    .extend(&nodes);
            }
            if let Some((kind, order)) = order {
                elements.push(MeshElement {
                    kind,
                    tag: element.element_tag,
                    nodes: order.iter().map(|&g| nodes[g]).collect(),
                });
            }
        }
    }
    // One group per name: physical groups of several dimensions under one name (a "root"
    // surface and its edges), or unnamed ones named by their tag (tags are numbered per
    // dimension), are the union of their nodes — deterministic, whatever the files' order.
    let mut named: BTreeMap<String, Vec<usize>> = BTreeMap::new();
    for ((dim, tag), nodes) in groups {
        let name = names
            .get(&(dim, tag))
            .cloned()
            .unwrap_or_else(|| tag.to_string());
        named.entry(name).or_default().extend(nodes);
    }
    let groups: Vec<NodeGroup> = named
        .into_iter()
        .map(|(name, mut nodes)| {
            nodes.sort_unstable();
            nodes.dedup();
            NodeGroup { name, nodes }
        })
        .collect();
    Ok(Mesh {
        nodes: tagged.into_iter().map(|(_, x)| x).collect(),
        elements,
        groups,
    })
}
