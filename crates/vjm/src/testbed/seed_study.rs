//! The seed paper's study (Hu, Wang, Pan: an extended VJM for a 7-DoF cobot, Table I) replayed
//! on a 7-joint chain: 8 identification and 5 verification configurations, two wrenches each,
//! traditional (7 torsional springs) versus extended (21 springs) model, both fitted by the
//! seed's ordinary least squares (eq. 12, minimum-norm where the extended model is
//! rank-deficient) on the identification rows.

use serde::Serialize;

use super::campaign::{simulate_at, CampaignSpec};
use super::truth::TrueModel;
use super::TestbedError;
use crate::chain::SerialChain;
use crate::diagnose::candidates::{spring_column, RowKinematics};
use crate::testbed::kinematics::deflected_pose;
use stiffness_core::engine::basis::solve_columns;

/// Table I of the seed, degrees: rows 1–8 identification, 9–13 verification.
pub const SEED_TABLE_I_DEG: [[f64; 7]; 13] = [
    [-30.0, 30.0, -30.0, -100.0, -160.0, 110.0, 0.0],
    [60.0, 30.0, 30.0, 100.0, -140.0, -100.0, 0.0],
    [80.0, -30.0, -20.0, 110.0, 0.0, 110.0, 0.0],
    [-60.0, -70.0, 30.0, 110.0, 0.0, 115.0, 0.0],
    [30.0, -45.0, 30.0, 110.0, 20.0, 110.0, 0.0],
    [-60.0, -60.0, -30.0, 100.0, -30.0, 100.0, 0.0],
    [-45.0, 30.0, -50.0, -115.0, 0.0, -110.0, 0.0],
    [0.0, 45.0, 0.0, -100.0, 160.0, 110.0, 0.0],
    [-30.0, 30.0, -30.0, 90.0, 160.0, -90.0, 0.0],
    [-45.0, 45.0, -100.0, 90.0, 160.0, -110.0, 0.0],
    [0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0],
    [0.0, -30.0, 0.0, -90.0, 0.0, -60.0, 0.0],
    [0.0, 30.0, 0.0, -90.0, 0.0, -120.0, 0.0],
];

/// The two wrenches applied at each configuration, base frame `[N; N·m]`. The first is the
/// seed's Section IV-B load; the seed does not list its second identification load, so the
/// second is our choice: a load of the same size pointing elsewhere.
pub const SEED_WRENCHES: [[f64; 6]; 2] = [
    [25.0, 35.0, 15.0, 6.0, 8.0, 9.0],
    [-30.0, 20.0, -25.0, -5.0, 7.0, -4.0],
];

/// A joint angle of Table I moved inside the chain's limits.
#[derive(Debug, Clone, Serialize)]
pub struct ClippedAngle {
    /// 1-based configuration of Table I.
    pub configuration: usize,
    /// 1-based joint.
    pub joint: usize,
    /// Table value, rad.
    pub table: f64,
    /// Value used, rad.
    pub used: f64,
}

/// Result of [`seed_study`]. Errors are means over rows of ‖d_pred − d_meas‖/‖d_meas‖.
#[derive(Debug, Clone, Serialize)]
pub struct SeedStudy {
    /// Traditional model on the 10 verification rows.
    pub traditional_verification_error: f64,
    /// Extended model on the 10 verification rows.
    pub extended_verification_error: f64,
    /// Traditional model on the 16 identification rows.
    pub traditional_identification_error: f64,
    /// Extended model on the 16 identification rows.
    pub extended_identification_error: f64,
    /// Traditional model over all 26 rows (the seed's 7.75 %).
    pub traditional_all_error: f64,
    /// Extended model over all 26 rows (the seed's 3.74 %).
    pub extended_all_error: f64,
    /// Rank of the extended model's identification matrix (≤ 21).
    pub extended_rank: usize,
    /// Mean share of the torsional springs in the true deflection norm, ‖J_t C_z Jᵀ W‖/‖d‖.
    pub torsion_share: f64,
    /// Joint angles moved inside the limits.
    pub clipped: Vec<ClippedAngle>,
}

impl TrueModel {
    /// The truth of the seed study: [`NOMINAL_TORSION`](super::NOMINAL_TORSION) plus tilting
    /// springs of `tilt_ratio` × the joint's torsional compliance about both tilt axes.
    pub fn with_tilts(torsion: &[f64], tilt_ratio: f64) -> Self {
        let mut t = TrueModel::torsion_only(torsion);
        for (j, c) in torsion.iter().enumerate() {
            t.compliance[3 * j + 1] = tilt_ratio * c;
            t.compliance[3 * j + 2] = tilt_ratio * c;
        }
        t
    }
}

fn mean_rel(pred: &[[f64; 3]], meas: &[[f64; 3]], rows: std::ops::Range<usize>) -> f64 {
    let n = rows.len() as f64;
    rows.map(|i| {
        let e = (0..3)
            .map(|k| (pred[i][k] - meas[i][k]).powi(2))
            .sum::<f64>()
            .sqrt();
        let d = (0..3).map(|k| meas[i][k].powi(2)).sum::<f64>().sqrt();
        e / d
    })
    .sum::<f64>()
        / n
}

/// Runs the seed's study on `chain` (7 actuated joints) with `truth`; `noise` adds the
/// default instrument noise drawn from `seed`.
pub fn seed_study(
    chain: &SerialChain,
    truth: &TrueModel,
    noise: bool,
    seed: u64,
) -> Result<SeedStudy, TestbedError> {
    let n = chain.n_joints();
    if n != 7 {
        return Err(TestbedError::InvalidSpec {
            field: "chain",
            message: format!("the seed's Table I is for 7 joints; the chain has {n}"),
        });
    }
    let mut clipped = Vec::new();
    let mut q = Vec::new();
    let mut wrenches = Vec::new();
    let mut poses = Vec::new();
    for (c, row) in SEED_TABLE_I_DEG.iter().enumerate() {
        let qc: Vec<f64> = row
            .iter()
            .zip(chain.limits())
            .enumerate()
            .map(|(j, (deg, &(lo, hi)))| {
                let table = deg.to_radians();
                let used = table.clamp(lo, hi);
                if used != table {
                    clipped.push(ClippedAngle {
                        configuration: c + 1,
                        joint: j + 1,
                        table,
                        used,
                    });
                }
                used
            })
            .collect();
        for w in SEED_WRENCHES {
            q.extend_from_slice(&qc);
            wrenches.push(w);
            poses.push(c as i64);
        }
    }
    let spec = CampaignSpec {
        noise,
        seed,
        ..Default::default()
    };
    let campaign = simulate_at(chain, truth, &q, &wrenches, &poses, &spec)?;
    let data = &campaign.dataset;
    let zeros = vec![0.0; 3 * n];
    let kin: Vec<RowKinematics> = (0..data.len())
        .map(|i| {
            let qi = data.q(i).to_vec();
            let pose = deflected_pose(chain, &qi, &zeros);
            let w = data.wrench(i);
            let tau = (pose.jacobian.transpose() * nalgebra::DVector::from_column_slice(&w))
                .iter()
                .cloned()
                .collect();
            RowKinematics {
                q: qi,
                jacobian: pose.jacobian,
                tau,
                wrench: w,
                displacement: data.displacement(i),
                tip: [pose.tip.x, pose.tip.y, pose.tip.z],
                tau_sigma: Vec::new(),
                tip_rotation: nalgebra::Matrix3::identity(),
                deflected: None,
            }
        })
        .collect();
    let meas: Vec<[f64; 3]> = (0..data.len()).map(|i| data.displacement(i)).collect();
    let n_id = 16;
    let fit = |springs: &[usize]| -> (Vec<[f64; 3]>, usize) {
        let cols: Vec<Vec<f64>> = springs
            .iter()
            .map(|&s| (0..n_id).flat_map(|i| spring_column(&kin[i], s)).collect())
            .collect();
        let y: Vec<f64> = (0..n_id).flat_map(|i| meas[i]).collect();
        let sol = solve_columns(&cols, &y);
        let (beta, rank) = (sol.beta, sol.rank);
        let pred = kin
            .iter()
            .map(|row| {
                let mut p = [0.0; 3];
                for (b, &s) in beta.iter().zip(springs) {
                    let c = spring_column(row, s);
                    for k in 0..3 {
                        p[k] += b * c[k];
                    }
                }
                p
            })
            .collect();
        (pred, rank)
    };
    let trad: Vec<usize> = (0..n).map(|j| 3 * j).collect();
    let ext: Vec<usize> = (0..3 * n).collect();
    let (p_trad, _) = fit(&trad);
    let (p_ext, extended_rank) = fit(&ext);
    let rows = data.len();
    // Torsion share of the true deflection.
    let torsion_truth = TrueModel {
        compliance: truth
            .compliance
            .iter()
            .enumerate()
            .map(|(s, c)| if s % 3 == 0 { *c } else { 0.0 })
            .collect(),
        effects: Vec::new(),
    };
    let torsion_share = (0..rows)
        .map(|i| {
            let (dt, _) = torsion_truth.displacement(chain, data.q(i), &campaign.applied_wrench[i]);
            let d = campaign.true_displacement[i];
            dt.norm() / (d[0] * d[0] + d[1] * d[1] + d[2] * d[2]).sqrt()
        })
        .sum::<f64>()
        / rows as f64;
    Ok(SeedStudy {
        traditional_verification_error: mean_rel(&p_trad, &meas, n_id..rows),
        extended_verification_error: mean_rel(&p_ext, &meas, n_id..rows),
        traditional_identification_error: mean_rel(&p_trad, &meas, 0..n_id),
        extended_identification_error: mean_rel(&p_ext, &meas, 0..n_id),
        traditional_all_error: mean_rel(&p_trad, &meas, 0..rows),
        extended_all_error: mean_rel(&p_ext, &meas, 0..rows),
        extended_rank,
        torsion_share,
        clipped,
    })
}
