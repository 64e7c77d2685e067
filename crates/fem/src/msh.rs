//! Reader of gmsh MSH 4.1 files (ASCII and binary), on top of mshio 0.4.2.
//!
//! - The volume mesh is every element of a 3-dimensional entity; all must be TET4 (gmsh type
//!   4) or all TET10 (type 11). gmsh saves only the elements of physical groups once any group
//!   exists, so this is the Physical Volume.
//! - Nodes are renumbered 0.. in file order, keeping only the nodes of the tetrahedra (a node
//!   that no tetrahedron uses would give an empty row in K and M).
//! - Physical groups of dimension 0..3 take their names from `$PhysicalNames` (a group without
//!   a name is named by its tag); a group's nodes are collected from the elements of its
//!   entities (points, lines, triangles, tetrahedra of any order), sorted and unique; a surface
//!   group (dim 2) also keeps its triangles (TRI3 on a TET4 mesh, TRI6 on a TET10 mesh; any
//!   other 2-D element is an error), for the loads on a surface (`surface_load`).

use std::collections::{BTreeMap, HashMap};
use std::path::Path;

use mshio::{ElementType, MshFile};

use crate::error::FemError;
use crate::mesh::{Mesh, PhysicalGroup};
use crate::msh_sections::{node_tags, physical_names, read_header};
use crate::tet_kind::TetKind;

/// Reads a gmsh MSH 4.1 file (ASCII or binary) into a [`Mesh`].
pub fn read_msh(path: &Path) -> Result<Mesh, FemError> {
    let bytes = std::fs::read(path).map_err(|source| FemError::Io {
        path: path.to_path_buf(),
        source,
    })?;
    parse_msh(&bytes, path)
}

/// Parses MSH 4.1 bytes; `path` is used in error messages only.
pub fn parse_msh(bytes: &[u8], path: &Path) -> Result<Mesh, FemError> {
    // Our own header check first: it names the version found, and rejects data sizes on
    // which mshio 0.4.2 would panic.
    let header = read_header(bytes, path)?;
    let msh = mshio::parse_msh_bytes(bytes).map_err(|e| FemError::MshParse {
        path: path.to_path_buf(),
        message: describe_parse_error(&e, bytes, header.ascii),
    })?;
    let names = physical_names(bytes, path)?;
    let tags = node_tags(bytes, header, path)?;
    build_mesh(&msh, &names, &tags, path)
}

/// Owned description of mshio's borrowing error: the error kind, where (line for ASCII, byte
/// offset for binary), and the chain of sections being parsed.
fn describe_parse_error(err: &mshio::MshParserError<&[u8]>, bytes: &[u8], ascii: bool) -> String {
    let trace = err.filtered_backtrace();
    let Some((input, kind)) = trace.first() else {
        return "malformed MSH 4.1 content".to_string();
    };
    let offset = (input.as_ptr() as usize)
        .saturating_sub(bytes.as_ptr() as usize)
        .min(bytes.len());
    let place = if ascii {
        let line = bytes[..offset].iter().filter(|&&b| b == b'\n').count() + 1;
        format!("line {line}")
    } else {
        format!("byte {offset}")
    };
    let context: Vec<String> = trace[1..]
        .iter()
        .rev()
        .map(|(_, k)| k.context().map_or_else(|| k.to_string(), str::to_string))
        .collect();
    let what = match kind.context() {
        Some(c) => format!("missing or malformed {c}"),
        None => kind.to_string(),
    };
    if context.is_empty() {
        format!("{what} (at {place})")
    } else {
        format!("{what} (at {place}, in {})", context.join(" > "))
    }
}

fn gmsh_type(t: ElementType) -> i32 {
    t as i32
}

/// Node coordinates in file order and the map from gmsh node tag to file index.
type FileNodes = (Vec<[f64; 3]>, HashMap<u64, usize>);

/// Maps gmsh node tags to indices in file order.
fn tag_index(
    msh: &MshFile<u64, i32, f64>,
    tags: &[Vec<u64>],
    path: &Path,
) -> Result<FileNodes, FemError> {
    let mut coords = Vec::new();
    let mut index = HashMap::new();
    let blocks = msh
        .data
        .nodes
        .as_ref()
        .map_or(&[][..], |n| &n.node_blocks[..]);
    if blocks.len() != tags.len() {
        return Err(FemError::MshParse {
            path: path.to_path_buf(),
            message: format!(
                "$Nodes: {} node blocks read, {} tag lists",
                blocks.len(),
                tags.len()
            ),
        });
    }
    for (block, block_tags) in blocks.iter().zip(tags) {
        if block.nodes.len() != block_tags.len() {
            return Err(FemError::MshParse {
                path: path.to_path_buf(),
                message: format!(
                    "$Nodes block of entity {}: {} coordinates but {} tags",
                    block.entity_tag,
                    block.nodes.len(),
                    block_tags.len()
                ),
            });
        }
        for (node, &tag) in block.nodes.iter().zip(block_tags) {
            if index.insert(tag, coords.len()).is_some() {
                return Err(FemError::MshParse {
                    path: path.to_path_buf(),
                    message: format!("node tag {tag} appears twice in $Nodes"),
                });
            }
            let xyz = [node.x, node.y, node.z];
            if !xyz.iter().all(|v| v.is_finite()) {
                return Err(FemError::MshNonFiniteCoordinate {
                    path: path.to_path_buf(),
                    node_tag: tag,
                    coords: xyz,
                });
            }
            coords.push(xyz);
        }
    }
    Ok((coords, index))
}

fn build_mesh(
    msh: &MshFile<u64, i32, f64>,
    names: &[crate::msh_sections::PhysicalName],
    tags: &[Vec<u64>],
    path: &Path,
) -> Result<Mesh, FemError> {
    let (file_coords, index) = tag_index(msh, tags, path)?;
    let lookup = |element_tag: u64, node_tag: u64| {
        index
            .get(&node_tag)
            .copied()
            .ok_or(FemError::UnknownNodeTag {
                path: path.to_path_buf(),
                element_tag: element_tag as usize,
                node_tag: node_tag as usize,
            })
    };
    let blocks = msh
        .data
        .elements
        .as_ref()
        .map_or(&[][..], |e| &e.element_blocks[..]);

    // Volume elements.
    let mut kind: Option<TetKind> = None;
    let mut file_connectivity = Vec::new();
    let mut element_tags = Vec::new();
    for block in blocks.iter().filter(|b| b.entity_dim == 3) {
        let this = match block.element_type {
            ElementType::Tet4 => TetKind::Tet4,
            ElementType::Tet10 => TetKind::Tet10,
            other => {
                return Err(FemError::UnsupportedVolumeElement {
                    path: path.to_path_buf(),
                    gmsh_type: gmsh_type(other),
                    type_name: format!("{other:?}"),
                    entity_tag: block.entity_tag,
                })
            }
        };
        if kind.is_some_and(|k| k != this) {
            return Err(FemError::MixedVolumeElements {
                path: path.to_path_buf(),
            });
        }
        kind = Some(this);
        for el in &block.elements {
            for &n in &el.nodes {
                file_connectivity.push(lookup(el.element_tag, n)?);
            }
            element_tags.push(el.element_tag as usize);
        }
    }
    let Some(kind) = kind.filter(|_| !element_tags.is_empty()) else {
        return Err(FemError::NoTetrahedra {
            path: path.to_path_buf(),
        });
    };

    // Keep only the nodes of the tetrahedra, in file order.
    const UNUSED: usize = usize::MAX;
    let mut new_index = vec![UNUSED; file_coords.len()];
    for &n in &file_connectivity {
        new_index[n] = 0;
    }
    let mut nodes = Vec::new();
    for (old, slot) in new_index.iter_mut().enumerate() {
        if *slot != UNUSED {
            *slot = nodes.len();
            nodes.push(file_coords[old]);
        }
    }
    let connectivity = file_connectivity.iter().map(|&n| new_index[n]).collect();

    // Physical groups: (dim, tag) -> name, entities -> physical tags.
    let mut groups: BTreeMap<(usize, i32), PhysicalGroup> = BTreeMap::new();
    for n in names {
        groups.insert(
            (n.dim, n.tag),
            PhysicalGroup {
                name: n.name.clone(),
                dim: n.dim,
                tag: n.tag,
                nodes: Vec::new(),
                triangles: Vec::new(),
            },
        );
    }
    let mut entity_groups: HashMap<(usize, i32), Vec<i32>> = HashMap::new();
    if let Some(ent) = &msh.data.entities {
        let all = ent
            .points
            .iter()
            .map(|e| (0, e.tag, &e.physical_tags))
            .chain(ent.curves.iter().map(|e| (1, e.tag, &e.physical_tags)))
            .chain(ent.surfaces.iter().map(|e| (2, e.tag, &e.physical_tags)))
            .chain(ent.volumes.iter().map(|e| (3, e.tag, &e.physical_tags)));
        for (dim, tag, phys) in all {
            for &p in phys {
                groups.entry((dim, p)).or_insert_with(|| PhysicalGroup {
                    name: p.to_string(),
                    dim,
                    tag: p,
                    nodes: Vec::new(),
                    triangles: Vec::new(),
                });
            }
            entity_groups.insert((dim, tag), phys.clone());
        }
    }
    // (physical tag, node tag) of every node of a point element of a dim-0 group.
    let mut point_uses: Vec<(i32, u64)> = Vec::new();
    for block in blocks {
        let Ok(dim) = usize::try_from(block.entity_dim) else {
            continue;
        };
        let Some(phys) = entity_groups.get(&(dim, block.entity_tag)) else {
            continue;
        };
        for &p in phys {
            let Some(group) = groups.get_mut(&(dim, p)) else {
                continue;
            };
            let point_group = dim == 0;
            let surface = dim == 2;
            if surface {
                check_surface_type(block.element_type, kind, &group.name, path)?;
            }
            for el in &block.elements {
                for &n in &el.nodes {
                    if point_group {
                        point_uses.push((p, n));
                    }
                    let mapped = new_index[lookup(el.element_tag, n)?];
                    if mapped == UNUSED {
                        return Err(FemError::GroupNodeOutsideVolume {
                            path: path.to_path_buf(),
                            group: group.name.clone(),
                            node_tag: n as usize,
                        });
                    }
                    group.nodes.push(mapped);
                    if surface {
                        group.triangles.push(mapped);
                    }
                }
            }
        }
    }
    check_point_groups(&mut point_uses, &groups, path)?;
    let groups = groups
        .into_values()
        .map(|mut g| {
            g.nodes.sort_unstable();
            g.nodes.dedup();
            g
        })
        .collect();

    let mesh = Mesh {
        nodes,
        kind,
        connectivity,
        element_tags,
        groups,
    };
    mesh.validate()?;
    Ok(mesh)
}

/// The 2-D elements of a surface group must be the faces of the volume's tetrahedra: TRI3
/// (gmsh type 2) on a TET4 mesh, TRI6 (type 9) on a TET10 mesh.
fn check_surface_type(
    found: ElementType,
    kind: TetKind,
    group: &str,
    path: &Path,
) -> Result<(), FemError> {
    let expected = match kind {
        TetKind::Tet4 => ElementType::Tri3,
        TetKind::Tet10 => ElementType::Tri6,
    };
    if found == expected {
        return Ok(());
    }
    Err(FemError::UnsupportedSurfaceElement {
        path: path.to_path_buf(),
        group: group.to_string(),
        gmsh_type: gmsh_type(found),
        type_name: format!("{found:?}"),
        expected: gmsh_type(expected),
        kind,
    })
}

/// Two point elements of one dim-0 group on the same mesh node would silently merge into one
/// group node (the group's node list is deduplicated): an error naming the group and node tag.
fn check_point_groups(
    uses: &mut [(i32, u64)],
    groups: &BTreeMap<(usize, i32), PhysicalGroup>,
    path: &Path,
) -> Result<(), FemError> {
    uses.sort_unstable();
    let Some(start) = uses.windows(2).position(|w| w[0] == w[1]) else {
        return Ok(());
    };
    let (group_tag, node_tag) = uses[start];
    let count = uses[start..]
        .iter()
        .take_while(|&&u| u == (group_tag, node_tag))
        .count();
    let group = groups
        .get(&(0, group_tag))
        .map_or_else(|| group_tag.to_string(), |g| g.name.clone());
    Err(FemError::DuplicateGroupNode {
        path: path.to_path_buf(),
        group,
        node_tag,
        count,
    })
}
