use std::path::PathBuf;
use vjm::Measurements;

use nalgebra::{Matrix3, Vector3};
use serde_json::{json, Value};
use so3_stiffness::identification::{
    identify, CsjmDataset, CsjmMeasurement, FitOptions, ReadOptions,
};
use so3_stiffness::so3;
use vjm::{IdentifyOptions, SerialChain, SolveMethod, VirtualJointModel};

/// Deterministic, irregular values in [-1, 1] (no RNG crate needed, identical everywhere).
/// Each column k has its own frequency: equal frequencies would make any three columns
/// linearly dependent (sin(x + 2e) = 2 cos e · sin(x + e) − sin x).
fn wave(i: usize, k: usize) -> f64 {
    let (i, k) = (i as f64 + 1.0, k as f64);
    (i * (1.618_033_988_75 + 0.371_9 * k) + std::f64::consts::E * k).sin()
}

fn mat_rows(m: &Matrix3<f64>) -> Value {
    json!([
        [m[(0, 0)], m[(0, 1)], m[(0, 2)]],
        [m[(1, 0)], m[(1, 1)], m[(1, 2)]],
        [m[(2, 0)], m[(2, 1)], m[(2, 2)]]
    ])
}

fn so3_part() -> Value {
    let mut w: Vec<Vector3<f64>> = (0..6)
        .map(|i| Vector3::new(wave(i, 0), wave(i, 1), wave(i, 2)) * (0.3 + 0.4 * i as f64))
        .collect();
    w.push(Vector3::new(1e-9, -2e-9, 3e-10)); // the Taylor branch
    w.push(Vector3::new(0.0, 0.0, std::f64::consts::PI - 1e-7)); // near π
    let exp: Vec<Value> = w.iter().map(|v| mat_rows(so3::exp(v).matrix())).collect();
    let log: Vec<Value> = w
        .iter()
        .map(|v| json!(so3::log(&so3::exp(v)).as_slice()))
        .collect();
    let jl: Vec<Value> = w.iter().map(|v| mat_rows(&so3::left_jacobian(v))).collect();
    let jr: Vec<Value> = w
        .iter()
        .map(|v| mat_rows(&so3::right_jacobian(v)))
        .collect();
    let w_json: Vec<Value> = w.iter().map(|v| json!(v.as_slice())).collect();
    json!({ "w": w_json, "exp": exp, "log_of_exp": log, "left_jacobian": jl, "right_jacobian": jr })
}

fn vjm_part() -> Value {
    let chain = SerialChain::bundled();
    let n = chain.n_joints();
    let rows = 60;
    let limits = chain.limits().to_vec();
    let mut q = Vec::with_capacity(rows * n);
    let mut w = Vec::with_capacity(rows * 6);
    for i in 0..rows {
        for (j, (lo, hi)) in limits.iter().enumerate() {
            let mid = 0.5 * (lo + hi);
            q.push(mid + 0.45 * (hi - lo) * wave(i, j));
        }
        for k in 0..6 {
            w.push(if k < 3 { 40.0 } else { 2.0 } * wave(i, 10 + k));
        }
    }
    // Displacements from a known extended model plus a deterministic "noise" of a few µm.
    let extended = VirtualJointModel::extended(n);
    let truth: Vec<f64> = (0..3 * n)
        .map(|k| if k % 3 == 0 { 1e-4 } else { 3e-5 } * (1.0 + 0.5 * wave(k, 30)))
        .collect();
    let mut d = Vec::with_capacity(rows * 3);
    for i in 0..rows {
        let mut f = [0.0; 6];
        f.copy_from_slice(&w[6 * i..6 * i + 6]);
        let di =
            vjm::predict_deflection(&chain, &extended, &truth, &q[n * i..n * (i + 1)], &f, false)
                .expect("valid inputs");
        for (k, dk) in di.iter().take(3).enumerate() {
            d.push(dk + 3e-6 * wave(i, 40 + k));
        }
    }
    // The streaming QR: its rounding does not depend on the CPU's vector width, whereas the
    // normal equations sum in lane order (16 lanes with AVX-512, 8 with AVX2) and their
    // standard errors differ between machines by ~1e-10 relative — more than this fixture's
    // 1e-12. The fixture checks the bindings, not the choice of reduction.
    let mut opts = IdentifyOptions::default();
    opts.method = SolveMethod::Qr;
    let mut ids = serde_json::Map::new();
    for (name, model) in [
        ("traditional", VirtualJointModel::traditional(n)),
        ("extended", VirtualJointModel::extended(n)),
    ] {
        let id = vjm::identify(&chain, &model, Measurements::new(&q, &w, &d), &opts)
            .expect("identifiable data");
        ids.insert(
            name.to_string(),
            json!({
                "rank": id.rank,
                "compliance": id.compliance,
                "stderr": id.stderr,
                "identifiable": id.identifiable,
            }),
        );
    }
    let jac_rows = 3;
    let mut jac = Vec::new();
    for i in 0..jac_rows {
        let j = vjm::jacobian(&chain, &extended, &q[n * i..n * (i + 1)]).expect("valid q");
        let rows: Vec<Vec<f64>> = (0..6)
            .map(|r| (0..j.ncols()).map(|c| j[(r, c)]).collect())
            .collect();
        jac.push(rows);
    }
    json!({
        "q": q.chunks(n).collect::<Vec<_>>(),
        "wrench": w.chunks(6).collect::<Vec<_>>(),
        "displacement": d.chunks(3).collect::<Vec<_>>(),
        "truth_extended": truth,
        "identify": ids,
        "jacobian_extended_first_rows": jac,
    })
}

fn csjm_part() -> Value {
    let k_true = Matrix3::new(30.0, 1.0, 0.5, 1.0, 28.0, -1.0, 0.5, -1.0, 7.0);
    let tau0 = Vector3::new(0.1, -0.5, 0.2);
    let k_d = k_true + 0.5 * so3::hat(&tau0);
    let r0 = so3::exp(&Vector3::new(0.1, 0.2, -0.1));
    let mut r_all = vec![mat_rows(r0.matrix())];
    let mut tau_all = vec![json!(tau0.as_slice())];
    let mut meas = Vec::new();
    for i in 0..12 {
        let z = Vector3::new(wave(i, 50), wave(i, 51), wave(i, 52)) * 0.02;
        let r = r0 * so3::exp(&z);
        // Slightly non-linear, with a deterministic perturbation, so stderr is non-zero.
        let t = tau0 + k_d * z + Vector3::new(wave(i, 53), wave(i, 54), wave(i, 55)) * 1e-3;
        r_all.push(mat_rows(r.matrix()));
        tau_all.push(json!(t.as_slice()));
        meas.push(CsjmMeasurement::new(r, t));
    }
    // Through the measurement-file reader, as a user with a file would: it projects every
    // accepted matrix onto SO(3), which is also what the Python array API does.
    let mut csv = String::from("r11,r12,r13,r21,r22,r23,r31,r32,r33,tx,ty,tz,ref\n");
    let rows =
        std::iter::once((r0, tau0, 1)).chain(meas.iter().map(|m| (m.orientation, m.moment, 0)));
    for (r, t, flag) in rows {
        let m = r.matrix();
        let fields: Vec<String> = (0..3)
            .flat_map(|i| (0..3).map(move |j| (i, j)))
            .map(|(i, j)| format!("{}", m[(i, j)]))
            .chain(t.iter().map(|v| format!("{v}")))
            .chain(std::iter::once(flag.to_string()))
            .collect();
        csv.push_str(&fields.join(","));
        csv.push('\n');
    }
    let data =
        CsjmDataset::from_csv_reader(csv.as_bytes(), &ReadOptions::default()).expect("valid file");
    let mut results = serde_json::Map::new();
    for order in [1u8, 2] {
        let opts = FitOptions::with_order(if order == 1 {
            so3_stiffness::identification::FitOrder::First
        } else {
            so3_stiffness::identification::FitOrder::Second
        });
        let est = identify(&data, &opts).expect("well-conditioned data");
        results.insert(
            format!("order{order}"),
            json!({
                "K": mat_rows(&est.k),
                "K_D": mat_rows(&est.k_d),
                "K_stderr": mat_rows(&est.k_stderr),
                "tau0": est.tau0.as_slice(),
                "n": est.n,
            }),
        );
    }
    json!({ "R": r_all, "tau": tau_all, "ref": 0, "fits": results })
}

fn reference() -> Value {
    json!({
        "about": "Results of the Rust core on deterministic inputs; checked by tests/it/reference.rs (Rust) and tests/test_reference.py (Python). Regenerate with UPDATE_REFERENCE=1 cargo test -p robot-stiffness-py.",
        "so3": so3_part(),
        "vjm": vjm_part(),
        "csjm": csjm_part(),
    })
}

fn path() -> PathBuf {
    PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("tests/data/reference.json")
}

#[test]
fn reference_file_matches_the_rust_core() {
    let current = reference();
    if std::env::var_os("UPDATE_REFERENCE").is_some() {
        let text = serde_json::to_string_pretty(&current).expect("serialisable") + "\n";
        std::fs::write(path(), text).expect("writable tests/data");
        return;
    }
    let text = std::fs::read_to_string(path())
        .expect("tests/data/reference.json exists (generate it with UPDATE_REFERENCE=1)");
    let stored: Value = serde_json::from_str(&text).expect("valid JSON");
    let mut mismatches = Vec::new();
    compare(&stored, &current, "", &mut mismatches);
    assert!(
        mismatches.is_empty(),
        "the Rust core's results changed ({}); if deliberate, rerun with UPDATE_REFERENCE=1 and commit the file",
        mismatches.join("; ")
    );
}

/// Leaves of `v` under `path`: numeric arrays are compared as a whole, relative to their
/// largest magnitude (serde_json's default float parser may be 1 ulp off, and an entry that
/// is zero up to rounding has no meaningful relative error of its own).
fn compare(a: &Value, b: &Value, path: &str, out: &mut Vec<String>) {
    const RTOL: f64 = 1e-12;
    match (a, b) {
        (Value::Object(x), Value::Object(y)) => {
            for (k, va) in x {
                match y.get(k) {
                    Some(vb) => compare(va, vb, &format!("{path}.{k}"), out),
                    None => out.push(format!("{path}.{k} missing")),
                }
            }
            if x.len() != y.len() {
                out.push(format!("{path}: different keys"));
            }
        }
        (Value::Array(x), Value::Array(y)) if x.iter().all(|v| v.is_number() || v.is_null()) => {
            if x.len() != y.len() {
                out.push(format!("{path}: length {} vs {}", x.len(), y.len()));
                return;
            }
            let scale = x
                .iter()
                .filter_map(Value::as_f64)
                .fold(0.0_f64, |m, v| m.max(v.abs()));
            for (i, (u, v)) in x.iter().zip(y).enumerate() {
                match (u.as_f64(), v.as_f64()) {
                    (Some(p), Some(q)) if (p - q).abs() <= RTOL * scale => {}
                    (None, None) => {}
                    _ => out.push(format!("{path}[{i}]: {u} vs {v}")),
                }
            }
        }
        (Value::Array(x), Value::Array(y)) => {
            if x.len() != y.len() {
                out.push(format!("{path}: length {} vs {}", x.len(), y.len()));
            }
            for (i, (u, v)) in x.iter().zip(y).enumerate() {
                compare(u, v, &format!("{path}[{i}]"), out);
            }
        }
        (u, v) if u.is_number() && v.is_number() => {
            let (p, q) = (
                u.as_f64().unwrap_or(f64::NAN),
                v.as_f64().unwrap_or(f64::NAN),
            );
            if p.is_nan() || q.is_nan() || (p - q).abs() > RTOL * p.abs().max(q.abs()) {
                out.push(format!("{path}: {u} vs {v}"));
            }
        }
        (u, v) if u != v => out.push(format!("{path}: {u} vs {v}")),
        _ => {}
    }
}
