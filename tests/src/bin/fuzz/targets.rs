//! What the harness feeds its inputs to: each reader and the calls its output feeds.
//!
//! A run ends with `Ok(summary)` or `Err(message)` (the library's error, as the user would see
//! it); a panic or a hang is the failure the harness looks for.

use so3_stiffness::identification::{self as csjm, CsjmDataset, FitOptions, FitOrder, ReadOptions};
use vjm::dataset::Dataset;
use vjm::testbed::{simulate, CampaignSpec, TrueModel};
use vjm::Measurements;
use vjm::{
    identify, jacobian, CompensateOptions, IdentifyOptions, Load, ModelError, SerialChain,
    SolveMethod, StiffnessModel, VirtualJointModel,
};

/// One reader (and what follows it).
#[derive(Debug, Clone, Copy, PartialEq, Eq, PartialOrd, Ord)]
pub enum Target {
    /// `vjm::dataset::Dataset::from_reader` for the bundled Panda (7 joints), then `identify`.
    VjmCsv,
    /// `CsjmDataset::from_csv_reader` (rejecting and projecting), then the CSJM `identify`.
    CsjmCsv,
    /// `SerialChain::from_urdf_str` with the base/tip named in the input's first-line comment,
    /// then kinematics, a small simulated campaign and `identify` on it.
    Urdf,
    /// `StiffnessModel::from_json` (a model file of the bundled Panda), then `check_robot`,
    /// `predict` and `compensate`; when only the content hash is wrong, the hash is recomputed
    /// and the file read again, as a user who edits a file by hand can do, so that the
    /// value checks behind the hash are fuzzed too.
    ModelFile,
}

impl Target {
    /// Every target, in a fixed order.
    pub const ALL: [Target; 4] = [
        Target::VjmCsv,
        Target::CsjmCsv,
        Target::Urdf,
        Target::ModelFile,
    ];

    /// Folder name of the target's seeds and crashes.
    pub fn name(self) -> &'static str {
        match self {
            Target::VjmCsv => "vjm",
            Target::CsjmCsv => "csjm",
            Target::Urdf => "urdf",
            Target::ModelFile => "model",
        }
    }

    /// Parses [`Target::name`].
    pub fn from_name(name: &str) -> Option<Self> {
        Self::ALL.into_iter().find(|t| t.name() == name)
    }

    /// Whether XML-aware mutations apply.
    pub fn is_xml(self) -> bool {
        self == Target::Urdf
    }

    /// Wire code of the worker protocol.
    pub fn code(self) -> u8 {
        self as u8
    }

    /// Inverse of [`Target::code`].
    pub fn from_code(code: u8) -> Option<Self> {
        Self::ALL.get(code as usize).copied()
    }

    /// Runs the input through the target.
    pub fn run(self, input: &[u8]) -> Result<String, String> {
        match self {
            Target::VjmCsv => run_vjm_csv(input),
            Target::CsjmCsv => run_csjm_csv(input),
            Target::Urdf => run_urdf(input),
            Target::ModelFile => run_model_file(input),
        }
    }
}

fn run_vjm_csv(input: &[u8]) -> Result<String, String> {
    let chain = SerialChain::bundled();
    let data = Dataset::from_reader(input, chain.n_joints()).map_err(|e| e.to_string())?;
    // Traditional model on translations (the default CLI run); the extended model with
    // rotations when the file has them (and the nonnegative fit), through the QR path. Each
    // step runs whatever the previous one answered: a result or an error is fine, a panic or
    // a hang is not.
    let traditional = VirtualJointModel::traditional(chain.n_joints());
    let extended = VirtualJointModel::extended(chain.n_joints());
    let with_rotation = data.rotation(0).is_some();
    let steps = [
        identify_dataset(&chain, &traditional, &data, false, SolveMethod::Auto, false),
        identify_dataset(
            &chain,
            &extended,
            &data,
            with_rotation,
            SolveMethod::Qr,
            true,
        ),
    ];
    Ok(format!("{} rows; {}", data.len(), steps.join("; ")))
}

/// Identifies on a read dataset; the rank, or the error message.
fn identify_dataset(
    chain: &SerialChain,
    model: &VirtualJointModel,
    data: &Dataset<'_>,
    with_rotation: bool,
    method: SolveMethod,
    nonnegative: bool,
) -> String {
    let rotation: Option<Vec<f64>> = with_rotation.then(|| {
        (0..data.len())
            .flat_map(|i| data.rotation(i).unwrap_or([0.0; 3]))
            .collect()
    });
    let mut opts = IdentifyOptions::default();
    opts.method = method;
    opts.use_rotations = with_rotation;
    opts.nonnegative = nonnegative;
    let result = identify(
        chain,
        model,
        Measurements::new(data.q_flat(), data.wrench_flat(), data.displacement_flat())
            .with_rotation(rotation.as_deref()),
        &opts,
    );
    match result {
        Ok(id) => format!("{} rank {}", model.name(), id.rank),
        Err(e) => format!("{}: {e}", model.name()),
    }
}

fn run_csjm_csv(input: &[u8]) -> Result<String, String> {
    let strict = CsjmDataset::from_csv_reader(input, &ReadOptions::default());
    let projected = CsjmDataset::from_csv_reader(input, &ReadOptions::projecting());
    let data = match (strict, projected) {
        (Ok(d), _) | (Err(_), Ok(d)) => d,
        (Err(e), Err(_)) => return Err(e.to_string()),
    };
    let first = csjm::identify(&data, &FitOptions::default()).map_err(|e| e.to_string())?;
    let second = csjm::identify(&data, &FitOptions::with_order(FitOrder::Second))
        .map_err(|e| e.to_string())?;
    Ok(format!(
        "{} poses, det K {:e} / {:e}",
        data.measurements().len(),
        first.k.determinant(),
        second.k.determinant()
    ))
}

/// Base and tip from a first-line comment `<!-- base=NAME tip=NAME -->` (else `base_link`,
/// `tool0`): mutations of the comment fuzz the link names too.
fn base_and_tip(xml: &str) -> (String, String) {
    let mut base = "base_link".to_string();
    let mut tip = "tool0".to_string();
    if let Some(comment) = xml.lines().next().and_then(|l| l.strip_prefix("<!--")) {
        for word in comment.split_whitespace() {
            if let Some(v) = word.strip_prefix("base=") {
                base = v.to_string();
            } else if let Some(v) = word.strip_prefix("tip=") {
                tip = v.to_string();
            }
        }
    }
    (base, tip)
}

fn run_urdf(input: &[u8]) -> Result<String, String> {
    let xml = String::from_utf8_lossy(input);
    let (base, tip) = base_and_tip(&xml);
    let chain = SerialChain::from_urdf_str(&xml, &base, &tip).map_err(|e| e.to_string())?;
    let n = chain.n_joints();
    let zero = vec![0.0; n];
    let mid: Vec<f64> = chain
        .limits()
        .iter()
        .map(|(lo, hi)| 0.5 * (lo + hi))
        .collect();
    chain.forward_kinematics(&zero).map_err(|e| e.to_string())?;
    let tip_pose = chain.forward_kinematics(&mid).map_err(|e| e.to_string())?;
    let extended = VirtualJointModel::extended(n);
    jacobian(&chain, &extended, &mid).map_err(|e| e.to_string())?;
    // What `simulate vjm` runs on a user's URDF, kept small.
    let spec = CampaignSpec {
        n_poses: 3,
        wrenches_per_pose: 2,
        seed: 1,
        ..CampaignSpec::default()
    };
    let campaign = simulate(&chain, &TrueModel::nominal(n), &spec).map_err(|e| e.to_string())?;
    let traditional = VirtualJointModel::traditional(n);
    let id = identify_dataset(
        &chain,
        &traditional,
        &campaign.dataset,
        false,
        SolveMethod::Auto,
        false,
    );
    Ok(format!(
        "{n} joints, tip at {:?}, {id}",
        tip_pose.translation.vector.as_slice()
    ))
}

fn run_model_file(input: &[u8]) -> Result<String, String> {
    let text = String::from_utf8_lossy(input);
    // The bundled arm's joints without its URDF text, so that the seeds stay valid when the
    // bundled URDF's text changes (its kinematics are still checked).
    let panda = SerialChain::bundled();
    let joints: Vec<vjm::JointSpec> = panda
        .joints()
        .iter()
        .map(|j| (j.name().to_string(), *j.origin(), *j.axis(), j.limits()))
        .collect();
    let chain = SerialChain::from_joints(
        vjm::BUNDLED_BASE,
        vjm::BUNDLED_FLANGE,
        joints,
        *panda.tip_offset(),
    )
    .map_err(|e| e.to_string())?;
    let model = match StiffnessModel::from_json(&text, "model.json") {
        Ok(m) => m,
        Err(ModelError::Edited { .. }) => {
            // Recompute the hash (the reader has bounded the text already) and read again.
            let mut doc: serde_json::Value =
                serde_json::from_str(&text).map_err(|e| e.to_string())?;
            let inner: StiffnessModel =
                serde_json::from_value(doc["model"].clone()).map_err(|e| e.to_string())?;
            doc["content_sha256"] = serde_json::Value::String(inner.content_sha256());
            StiffnessModel::from_json(&doc.to_string(), "model.json").map_err(|e| e.to_string())?
        }
        Err(e) => return Err(e.to_string()),
    };
    model
        .check_robot(&chain, "model.json")
        .map_err(|e| e.to_string())?;
    let n = chain.n_joints();
    let mid: Vec<f64> = chain
        .limits()
        .iter()
        .map(|(lo, hi)| 0.5 * (lo + hi))
        .collect();
    let q: Vec<f64> = [vec![0.0; n], mid].concat();
    let wrench = [
        [40.0, -20.0, 10.0, 1.0, 0.5, -2.0],
        [0.0, 0.0, -50.0, 0.0, 0.0, 0.0],
    ]
    .concat();
    let predicted = model
        .predict(&chain, &q, Load::Wrench(&wrench))
        .map_err(|e| e.to_string())?;
    let sd = model.measurement_stddev();
    if sd.iter().any(|s| *s < 0.0) {
        // A negative standard deviation is a silent wrong answer, not an error.
        panic!("measurement_stddev {sd:?} < 0 from a file the reader accepted");
    }
    let compensated = model
        .compensate(
            &chain,
            &q,
            Load::Wrench(&wrench),
            &CompensateOptions::default(),
        )
        .map_err(|e| e.to_string())?;
    Ok(format!(
        "{} rows predicted ({} identified), {} compensated",
        predicted.len(),
        predicted.iter().filter(|p| p.identified).count(),
        compensated.rows.len()
    ))
}
