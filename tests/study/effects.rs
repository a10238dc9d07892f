//! What the study hides in a campaign: nothing (false alarms), one catalogue effect at a stated
//! magnitude, one effect outside the catalogue, or two effects at once; and what counts as
//! detecting it.

use vjm::diagnose::report::Diagnosis;
use vjm::testbed::{CampaignSpec, Effect, HarmonicDriveSpring, TrueModel};
use vjm::{jacobian, SerialChain, SpringAxis, VirtualJointModel};

/// Joint (0-based) that carries the joint effects: joint 2, the shoulder, which carries the
/// largest torques on every arm of the study.
pub const EFFECT_JOINT: usize = 1;

/// One hidden effect with its magnitude (with its unit: [`Hidden::magnitude`]).
#[derive(Debug, Clone, PartialEq)]
pub enum Hidden {
    /// Nothing: the torsion-only truth.
    Clean,
    /// Tilt of joint 2 about x, compliance = `fraction` × that joint's torsional compliance.
    Tilt(f64),
    /// Harmonic-drive stiffening of joint 2: k2 = r·k1, k3 = r²·k1, knots at 0.3 and 0.8 × the
    /// joint's RMS torque in the campaign.
    TorsionNonlinear(f64),
    /// Backlash of joint 2, full dead band in arcmin.
    Backlash(f64),
    /// Wrench bias: force `b` N along (1, −0.5, 0.7)/‖·‖ and moment 0.1·b N·m along
    /// (0.3, 0.2, −0.4)/‖·‖ (b/10).
    WrenchBias(f64),
    /// Tracker frame rotated by `m` mrad about (0.3, −0.8, 0.5)/‖·‖.
    Misalignment(f64),
    /// Geometric non-linearity (K_C) with force and moment ranges scaled by `s`.
    Geometric(f64),
    /// Compliant mount, k (N/m) in translation and k·1 m² (N·m/rad) in rotation.
    Mount(f64),
    /// Tool compliant along its axis, k_tool in N/m.
    Tool(f64),
    /// The link after joint 2 translates along its x axis, k in N/m (issue 23's compliant link).
    LinkTranslation(f64),
    /// Pose drift, per-axis σ in µm.
    Drift(f64),
    /// Force-sensor cross-axis sensitivity, in % (outside the catalogue).
    Crosstalk(f64),
    /// Joint 2's torsion compliance varies with its angle, c·(1 + a·sin q₂), a the relative
    /// amplitude (outside the catalogue; issue 23's pose-dependent compliance).
    AngleDependent(f64),
    /// Two effects at once.
    Pair(Box<Hidden>, Box<Hidden>),
}

fn unit3(v: [f64; 3]) -> [f64; 3] {
    let n = (v[0] * v[0] + v[1] * v[1] + v[2] * v[2]).sqrt();
    [v[0] / n, v[1] / n, v[2] / n]
}

impl Hidden {
    /// The effect family's name in the tables.
    pub fn family(&self) -> String {
        match self {
            Hidden::Clean => "clean".into(),
            Hidden::Tilt(_) => "joint_tilt J2x".into(),
            Hidden::TorsionNonlinear(_) => "joint_torsion_nonlinear J2".into(),
            Hidden::Backlash(_) => "joint_backlash J2".into(),
            Hidden::WrenchBias(_) => "wrench_bias".into(),
            Hidden::Misalignment(_) => "frame_misalignment".into(),
            Hidden::Geometric(_) => "geometric_nonlinearity".into(),
            Hidden::Mount(_) => "mount_translation/rotation".into(),
            Hidden::Tool(_) => "tool axial compliance".into(),
            Hidden::LinkTranslation(_) => "link_translation J2x".into(),
            Hidden::Drift(_) => "pose drift (outside)".into(),
            Hidden::Crosstalk(_) => "F/T cross-talk (outside)".into(),
            Hidden::AngleDependent(_) => "torsion varying with the angle J2 (outside)".into(),
            Hidden::Pair(a, b) => format!("{} + {}", a.family(), b.family()),
        }
    }

    /// The magnitude with its unit, for the tables.
    pub fn magnitude(&self) -> String {
        match self {
            Hidden::Clean => "—".into(),
            Hidden::Tilt(f) => format!("{f} × torsion"),
            Hidden::TorsionNonlinear(r) => format!("ratio {r}"),
            Hidden::Backlash(a) => format!("{a} arcmin"),
            Hidden::WrenchBias(b) => format!("{b} N, {} N·m", b / 10.0),
            Hidden::Misalignment(m) => format!("{m} mrad"),
            Hidden::Geometric(s) => format!("loads × {s}"),
            Hidden::Mount(k) => format!("k = {k:.1e} N/m"),
            Hidden::Tool(k) | Hidden::LinkTranslation(k) => format!("k = {k:.1e} N/m"),
            Hidden::Drift(s) => format!("σ = {s} µm"),
            Hidden::Crosstalk(c) => format!("{c} %"),
            Hidden::AngleDependent(a) => format!("± {} %", 100.0 * a),
            Hidden::Pair(a, b) => format!("{}; {}", a.magnitude(), b.magnitude()),
        }
    }

    /// Whether the effect is outside the catalogue (detected = `unexplained: true`). The
    /// compliant mount joined the catalogue with the shared engine (`mount_translation`,
    /// `mount_rotation`), the compliant tool with the link translations (issue 23: a tool
    /// compliant along its axis is a translation of the last link along it).
    pub fn outside(&self) -> bool {
        matches!(
            self,
            Hidden::Drift(_) | Hidden::Crosstalk(_) | Hidden::AngleDependent(_)
        )
    }

    /// Whether the effect acts on the arm (its springs, mount, links, tool) rather than on the
    /// instruments: then its noise-free signal is the true displacement with the effect minus
    /// that without it at the same applied wrenches, and its detectability λ
    /// (`vjm::diagnose::detectability`, docs/diagnose.md §4) is what the study reports per run.
    /// A wrench bias, a misalignment, drift and cross-talk change what is recorded, not the
    /// displacement; pairs mix both.
    pub fn arm_side(&self) -> bool {
        !matches!(
            self,
            Hidden::Clean
                | Hidden::WrenchBias(_)
                | Hidden::Misalignment(_)
                | Hidden::Drift(_)
                | Hidden::Crosstalk(_)
                | Hidden::Pair(..)
        )
    }

    /// The campaign spec: the study's defaults, loads scaled for K_C.
    pub fn spec(&self, base: &CampaignSpec) -> CampaignSpec {
        match self {
            Hidden::Geometric(s) => CampaignSpec {
                force_range: (base.force_range.0 * s, base.force_range.1 * s),
                moment_max: base.moment_max * s,
                ..base.clone()
            },
            Hidden::Pair(a, b) => b.spec(&a.spec(base)),
            _ => base.clone(),
        }
    }

    /// The true model: `torsion` springs plus the effect(s). `rms_torque` is joint 2's RMS
    /// torsion torque in the campaign (for the harmonic-drive knots).
    pub fn truth(&self, torsion: &[f64], rms_torque: f64) -> TrueModel {
        let mut t = TrueModel::torsion_only(torsion);
        for e in self.effects(torsion, rms_torque) {
            t = t.with_effect(e);
        }
        t
    }

    fn effects(&self, torsion: &[f64], rms_torque: f64) -> Vec<Effect> {
        let j = EFFECT_JOINT;
        match self {
            Hidden::Clean => vec![],
            Hidden::Tilt(f) => vec![Effect::JointTilt {
                joint: j,
                axis: SpringAxis::X,
                compliance: f * torsion[j],
            }],
            Hidden::TorsionNonlinear(r) => vec![Effect::TorsionNonlinear {
                joint: j,
                spring: HarmonicDriveSpring::stiffening(
                    torsion[j],
                    *r,
                    0.3 * rms_torque,
                    0.8 * rms_torque,
                ),
            }],
            Hidden::Backlash(arcmin) => vec![Effect::Backlash {
                joint: j,
                lost_motion: arcmin / 60.0 * std::f64::consts::PI / 180.0,
            }],
            Hidden::WrenchBias(b) => {
                let f = unit3([1.0, -0.5, 0.7]);
                let m = unit3([0.3, 0.2, -0.4]);
                vec![Effect::WrenchBias {
                    bias: [
                        b * f[0],
                        b * f[1],
                        b * f[2],
                        b / 10.0 * m[0],
                        b / 10.0 * m[1],
                        b / 10.0 * m[2],
                    ],
                }]
            }
            Hidden::Misalignment(mrad) => {
                let a = unit3([0.3, -0.8, 0.5]);
                let r = mrad * 1e-3;
                vec![Effect::FrameMisalignment {
                    rotation: [r * a[0], r * a[1], r * a[2]],
                }]
            }
            Hidden::Geometric(_) => vec![Effect::GeometricNonlinearity],
            Hidden::Mount(k) => vec![Effect::MountCompliance {
                translation: 1.0 / k,
                rotation: 1.0 / k,
            }],
            Hidden::LinkTranslation(k) => vec![Effect::LinkTranslation {
                joint: j,
                axis: SpringAxis::X,
                compliance: 1.0 / k,
            }],
            Hidden::Tool(k) => vec![Effect::ToolAxialCompliance {
                compliance: 1.0 / k,
            }],
            Hidden::Drift(um) => vec![Effect::PoseDrift { sigma: um * 1e-6 }],
            Hidden::Crosstalk(c) => vec![Effect::SensorCrosstalk {
                coupling: c / 100.0,
            }],
            Hidden::AngleDependent(a) => vec![Effect::TorsionAngleDependent {
                joint: j,
                amplitude: *a,
            }],
            Hidden::Pair(a, b) => {
                let mut v = a.effects(torsion, rms_torque);
                v.extend(b.effects(torsion, rms_torque));
                v
            }
        }
    }

    /// Whether `d` detects the effect: a catalogue effect is named (finding or alias, right
    /// joint and axis; a torsion non-linearity also counts when backlash at the joint is named
    /// with the torsion candidate as its alias, as in the crate's property test); an effect
    /// outside the catalogue is flagged `unexplained`; a pair needs both. A compliant tool is
    /// named when a `link_translation` along one of `tool_axes` (1-based joint, axis: the
    /// spring axes that stay parallel to the tool's axis, [`tool_axis_translations`]) is, or
    /// flagged `unexplained`.
    pub fn detected(&self, d: &Diagnosis, tool_axes: &[(usize, String)]) -> bool {
        let jj = Some(EFFECT_JOINT + 1);
        match self {
            Hidden::Clean => d.findings.is_empty() && !d.unexplained,
            Hidden::Tilt(_) => named(d, "joint_tilt", jj, Some("x")),
            Hidden::TorsionNonlinear(_) => {
                named(d, "joint_torsion_nonlinear", jj, None)
                    || d.findings.iter().any(|f| {
                        f.effect == "joint_backlash"
                            && f.joint == jj
                            && f.aliases
                                .iter()
                                .any(|a| a.effect == "joint_torsion_nonlinear" && a.joint == jj)
                    })
            }
            Hidden::Backlash(_) => named(d, "joint_backlash", jj, None),
            Hidden::WrenchBias(_) => named(d, "wrench_bias", None, None),
            Hidden::Misalignment(_) => named(d, "frame_misalignment", None, None),
            Hidden::Geometric(_) => named(d, "geometric_nonlinearity", None, None),
            Hidden::Mount(_) => {
                named(d, "mount_translation", None, None) || named(d, "mount_rotation", None, None)
            }
            Hidden::LinkTranslation(_) => named(d, "link_translation", jj, Some("x")),
            Hidden::Tool(_) => {
                d.unexplained
                    || tool_axes
                        .iter()
                        .any(|(j, a)| named(d, "link_translation", Some(*j), Some(a)))
            }
            Hidden::Drift(_) | Hidden::Crosstalk(_) | Hidden::AngleDependent(_) => d.unexplained,
            Hidden::Pair(a, b) => a.detected(d, tool_axes) && b.detected(d, tool_axes),
        }
    }
}

/// Whether `d` names `effect` at `joint` (1-based) / `axis`, as a finding or an alias.
pub fn named(d: &Diagnosis, effect: &str, joint: Option<usize>, axis: Option<&str>) -> bool {
    d.findings.iter().any(|f| {
        (f.effect == effect && f.joint == joint && f.axis.as_deref() == axis)
            || f.aliases
                .iter()
                .any(|a| a.effect == effect && a.joint == joint && a.axis.as_deref() == axis)
    })
}

/// The link translations along the tool's axis: every (1-based joint, spring axis) whose axis
/// is parallel to the tip frame's z (the testbed's tool axis) at every configuration of
/// `q_rows`. Their column a (a·f) is the compliant tool's exactly: the diagnosis may name any.
pub fn tool_axis_translations(chain: &SerialChain, q_rows: &[Vec<f64>]) -> Vec<(usize, String)> {
    if q_rows.is_empty() {
        return Vec::new();
    }
    // Per configuration: the joints' frames and the tool axis, computed once.
    let poses: Vec<_> = q_rows
        .iter()
        .map(|q| {
            let frames = chain.joint_frames(q).expect("q matches the chain");
            let tool = chain
                .forward_kinematics(q)
                .expect("q matches the chain")
                .rotation
                * nalgebra::Vector3::z();
            (frames, tool)
        })
        .collect();
    let mut out = Vec::new();
    for (j, joint) in chain.joints().iter().enumerate() {
        let local = vjm::spring_axes(joint.axis());
        for (e, axis) in local.iter().zip(SpringAxis::ALL) {
            let parallel = poses.iter().all(|(frames, tool)| {
                let a = frames[j].rotation * e;
                (a.dot(tool).abs() - 1.0).abs() < 1e-9
            });
            if parallel {
                out.push((j + 1, axis.to_string()));
            }
        }
    }
    out
}

/// RMS over rows of joint `j`'s torsion torque `J_z(q)ᵀ W` under the applied wrenches, N·m.
pub fn rms_torque(
    chain: &SerialChain,
    q_rows: &[Vec<f64>],
    wrenches: &[[f64; 6]],
    j: usize,
) -> f64 {
    let model = VirtualJointModel::traditional(chain.n_joints());
    let mut sum = 0.0;
    for (q, w) in q_rows.iter().zip(wrenches) {
        let jac = jacobian(chain, &model, q).expect("q matches the chain");
        let tau: f64 = (0..6).map(|k| jac[(k, j)] * w[k]).sum();
        sum += tau * tau;
    }
    (sum / q_rows.len().max(1) as f64).sqrt()
}

/// The catalogue effects at 4 magnitudes each: from below the detection threshold (to show
/// where it lies) up into the realistic ranges of docs/diagnose.md.
pub fn catalogue_grid() -> Vec<Hidden> {
    let mut v = Vec::new();
    v.extend([0.003, 0.01, 0.03, 0.1].map(Hidden::Tilt));
    v.extend([1.02, 1.05, 1.1, 1.3].map(Hidden::TorsionNonlinear));
    v.extend([0.05, 0.1, 0.25, 1.0].map(Hidden::Backlash));
    v.extend([0.1, 0.25, 0.5, 1.0].map(Hidden::WrenchBias));
    v.extend([1.0, 2.0, 5.0, 10.0].map(Hidden::Misalignment));
    v.extend([0.5, 1.0, 1.5, 2.0].map(Hidden::Geometric));
    v.extend([1e6, 5e5, 2.5e5, 1e5].map(Hidden::Mount));
    v.extend([1e7, 3e6, 1e6, 3e5].map(Hidden::LinkTranslation));
    v
}

/// The effects outside the catalogue at 4 magnitudes each (the mount at k = 2.5e5 N/m and
/// the compliant tool are the cases of issue 11).
pub fn outside_grid() -> Vec<Hidden> {
    let mut v = Vec::new();
    v.extend([1e6, 1e5, 3e4, 1e4].map(Hidden::Tool));
    v.extend([3.0, 5.0, 10.0, 20.0].map(Hidden::Drift));
    v.extend([1.0, 2.0, 5.0, 10.0].map(Hidden::Crosstalk));
    v.extend([0.05, 0.1, 0.2, 0.4].map(Hidden::AngleDependent));
    v
}

/// Two effects at once, each at a magnitude it is detected at alone in ≥ 95 % of runs on
/// every robot (see the power table): the question is whether both are named together.
pub fn pair_grid() -> Vec<Hidden> {
    vec![
        Hidden::Pair(
            Box::new(Hidden::Tilt(0.1)),
            Box::new(Hidden::WrenchBias(1.0)),
        ),
        Hidden::Pair(
            Box::new(Hidden::Backlash(1.0)),
            Box::new(Hidden::Misalignment(10.0)),
        ),
    ]
}
