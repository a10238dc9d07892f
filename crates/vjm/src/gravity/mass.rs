//! The rigid bodies a serial chain carries, from the URDF's `<inertial>` elements.
//!
//! Actuated joint j carries one rigid body: its child link and everything attached to it
//! up to the next actuated joint of the chain — links behind fixed joints on the chain, and
//! every subtree that branches off it (a hand, its fingers, a camera). The last actuated
//! joint also carries everything beyond the tip link. Movable joints off the chain (a
//! gripper's fingers) are frozen at position 0: the arm's weight does not depend on them to
//! the accuracy of a stiffness model, and the chain has no coordinate for them.

use std::collections::{HashMap, HashSet};

use nalgebra::{Isometry3, Point3, Vector3};

use crate::chain::pose_to_isometry as pose;

use crate::error::VjmError;

/// The rigid body carried by one actuated joint: total mass and centre of mass.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Body {
    /// Mass, kg (≥ 0).
    pub mass: f64,
    /// Centre of mass in the joint's child frame, m (zero for a massless body).
    pub com: Vector3<f64>,
}

/// The masses a [`SerialChain`](crate::SerialChain) carries: one [`Body`] per actuated
/// joint, base → tip. Built by the chain from its URDF (see the module docs); what is
/// upstream of the first actuated joint rests on the base and has no effect.
#[derive(Debug, Clone, PartialEq)]
pub struct MassModel {
    bodies: Vec<Body>,
}

impl MassModel {
    /// A mass model from one body per actuated joint (masses finite and ≥ 0, centres finite).
    pub fn new(bodies: Vec<Body>) -> Result<Self, VjmError> {
        for (j, b) in bodies.iter().enumerate() {
            if let Some(message) = invalid_mass(b.mass, &b.com) {
                return Err(VjmError::InvalidInertial {
                    link: format!("(the body of actuated joint {})", j + 1),
                    message,
                });
            }
        }
        Ok(Self { bodies })
    }

    /// The bodies, one per actuated joint, base → tip.
    pub fn bodies(&self) -> &[Body] {
        &self.bodies
    }

    /// Total mass carried by the first actuated joint, kg.
    pub fn total_mass(&self) -> f64 {
        self.bodies.iter().map(|b| b.mass).sum()
    }
}

/// Why a mass or centre of mass cannot be a body's, or `None` when it can.
fn invalid_mass(mass: f64, com: &Vector3<f64>) -> Option<String> {
    if !(mass.is_finite() && mass >= 0.0) {
        return Some(format!("mass {mass:e} kg: it must be finite and ≥ 0"));
    }
    if !com.iter().all(|c| c.is_finite()) {
        return Some("centre of mass is not finite".to_string());
    }
    None
}

/// What the chain knows of its masses: a model, or the reason there is none.
#[derive(Debug, Clone)]
pub(crate) enum MassSource {
    Known(MassModel),
    /// A link carried by the chain cannot give its weight (`message` says why).
    Unusable {
        link: String,
        message: String,
    },
    /// Built without a URDF ([`SerialChain::from_joints`](crate::SerialChain::from_joints)).
    None,
}

impl MassSource {
    /// The mass model, or the error that says why there is none.
    pub(crate) fn get(&self) -> Result<&MassModel, VjmError> {
        match self {
            MassSource::Known(m) => Ok(m),
            MassSource::Unusable { link, message } => Err(VjmError::InvalidInertial {
                link: link.clone(),
                message: message.clone(),
            }),
            MassSource::None => Err(VjmError::InvalidInertial {
                link: "(none)".to_string(),
                message: "the chain was not built from a URDF, so its masses are unknown; \
                          give them with SerialChain::with_masses"
                    .to_string(),
            }),
        }
    }
}

/// Whether a link lacks an `<inertial>` that its shape needs: a link with a visual or
/// collision shape must weigh something, a link without one is a massless frame (a flange, a
/// tool centre point). urdf-rs parses a missing `<inertial>` as mass 0 with a zero inertia,
/// like an explicit `<mass value="0"/>` (UR's `ee_link`); `declared`, the links whose text
/// has an `<inertial>` element, tells the two apart where the URDF text is known.
fn missing_inertial(link: &urdf_rs::Link, declared: Option<&HashSet<String>>) -> bool {
    if link.visual.is_empty() && link.collision.is_empty() {
        return false;
    }
    match declared {
        Some(set) => !set.contains(&link.name),
        None => {
            let i = &link.inertial;
            let zero_inertia = [i.inertia.ixx, i.inertia.iyy, i.inertia.izz] == [0.0; 3];
            i.mass.value == 0.0 && zero_inertia
        }
    }
}

/// The names of the links whose element in the URDF text contains an `<inertial>` element:
/// one linear scan (no recursion, no allocation per character), comments skipped. Links are
/// never nested in a URDF, so a link's element ends at the next `</link>`.
pub(crate) fn links_declaring_inertial(xml: &str) -> HashSet<String> {
    let mut out = HashSet::new();
    let mut rest = xml;
    while let Some(at) = rest.find('<') {
        rest = &rest[at..];
        if let Some(body) = rest.strip_prefix("<!--") {
            rest = body.find("-->").map_or("", |end| &body[end + 3..]);
            continue;
        }
        let Some(tag) = rest.strip_prefix("<link") else {
            rest = &rest[1..];
            continue;
        };
        if !tag.starts_with(|c: char| c.is_whitespace() || c == '>' || c == '/') {
            rest = &rest[1..];
            continue;
        }
        let Some(close) = tag.find('>') else { break };
        let head = &tag[..close];
        rest = &tag[close + 1..];
        if head.ends_with('/') {
            continue; // <link name="..."/>: no children
        }
        let Some(name) = attribute(head, "name") else {
            continue;
        };
        let end = rest.find("</link").unwrap_or(rest.len());
        if strip_comments_contains(&rest[..end], "<inertial") {
            out.insert(name.to_string());
        }
        rest = &rest[end..];
    }
    out
}

/// The value of attribute `key` in a start tag's text (`name="x"` or `name='x'`).
fn attribute<'a>(head: &'a str, key: &str) -> Option<&'a str> {
    let mut from = 0;
    while let Some(i) = head[from..].find(key) {
        let at = from + i;
        let before_ok = at == 0 || head[..at].ends_with(|c: char| c.is_whitespace());
        let after = head[at + key.len()..].trim_start();
        if before_ok {
            if let Some(after) = after.strip_prefix('=') {
                let after = after.trim_start();
                let quote = after.chars().next()?;
                if quote == '"' || quote == '\'' {
                    let value = &after[1..];
                    return value.find(quote).map(|end| &value[..end]);
                }
            }
        }
        from = at + key.len();
    }
    None
}

/// Whether `text` contains `needle` outside `<!-- -->` comments.
fn strip_comments_contains(text: &str, needle: &str) -> bool {
    let mut rest = text;
    loop {
        match (rest.find(needle), rest.find("<!--")) {
            (None, _) => return false,
            (Some(n), Some(c)) if c < n => {
                rest = rest[c + 4..]
                    .find("-->")
                    .map_or("", |end| &rest[c + 4 + end + 3..]);
            }
            (Some(_), _) => return true,
        }
    }
}

/// The bodies carried by the actuated joints whose URDF indices (base → tip) are
/// `actuated`: joint j's body is collected from its child link through every joint except
/// `actuated[j + 1]`, with an explicit stack (no recursion: URDF trees can be deep).
pub(crate) fn mass_source(
    robot: &urdf_rs::Robot,
    actuated: &[usize],
    declared: Option<&HashSet<String>>,
) -> MassSource {
    let links: HashMap<&str, &urdf_rs::Link> =
        robot.links.iter().map(|l| (l.name.as_str(), l)).collect();
    let mut children: HashMap<&str, Vec<usize>> = HashMap::new();
    for (i, j) in robot.joints.iter().enumerate() {
        children.entry(j.parent.link.as_str()).or_default().push(i);
    }
    let mut bodies = Vec::with_capacity(actuated.len());
    let cap = robot.links.len() + 1;
    for (k, &ji) in actuated.iter().enumerate() {
        let stop = actuated.get(k + 1).copied();
        let root = robot.joints[ji].child.link.as_str();
        let (mut mass, mut moment) = (0.0, Vector3::zeros());
        // (link, pose of the link frame in joint ji's child frame)
        let mut stack = vec![(root, Isometry3::identity())];
        let mut visited = 0usize;
        while let Some((name, frame)) = stack.pop() {
            visited += 1;
            if visited > cap {
                break; // a cycle; the chain's own walk reports closed chains
            }
            if let Some(link) = links.get(name) {
                if missing_inertial(link, declared) {
                    return MassSource::Unusable {
                        link: name.to_string(),
                        message: "it has a visual or collision shape but no <inertial>: give its \
                                  mass and centre of mass, or turn gravity off"
                            .to_string(),
                    };
                }
                let m = link.inertial.mass.value;
                let com = frame * pose(&link.inertial.origin) * Point3::origin();
                if let Some(message) = invalid_mass(m, &com.coords) {
                    return MassSource::Unusable {
                        link: name.to_string(),
                        message: format!("<inertial>: {message}"),
                    };
                }
                mass += m;
                moment += com.coords * m;
            }
            for &c in children.get(name).map(Vec::as_slice).unwrap_or(&[]) {
                if Some(c) != stop {
                    let joint = &robot.joints[c];
                    stack.push((joint.child.link.as_str(), frame * pose(&joint.origin)));
                }
            }
        }
        let com = if mass > 0.0 {
            moment / mass
        } else {
            Vector3::zeros()
        };
        bodies.push(Body { mass, com });
    }
    // A chain that weighs nothing is a URDF without inertials (the bundled Panda), not a
    // weightless arm: say so rather than predict no sag.
    if bodies.iter().all(|b| b.mass == 0.0) {
        if let Some(&first) = actuated.first() {
            return MassSource::Unusable {
                link: robot.joints[first].child.link.clone(),
                message: "no link the chain carries has a mass in an <inertial> element; \
                          gravity needs the URDF's inertials (or turn gravity off)"
                    .to_string(),
            };
        }
    }
    // Every link was checked above, so the sums are finite.
    MassSource::Known(MassModel { bodies })
}
