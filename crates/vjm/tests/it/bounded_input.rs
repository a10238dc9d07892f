//! Issue 21: inputs that reach recursive parsers are bounded before parsing (a deeply nested
//! URDF overflowed urdf-rs' stack; 200 000 `[` in a model file gave a recursion error), model
//! files with impossible values are refused even when their hash was recomputed, and messages
//! quote a user's number short (1e308, not 309 digits).

use serde_json::Value;
use vjm::bounded::{
    TextLimitError, MODEL_FILE_MAX_BYTES, MODEL_FILE_MAX_DEPTH, URDF_MAX_BYTES, URDF_MAX_DEPTH,
};
use vjm::dataset::Dataset;
use vjm::testbed::CampaignSpec;
use vjm::Measurements;
use vjm::{
    identify, IdentifyOptions, ModelError, SerialChain, StiffnessModel, VirtualJointModel,
    VjmError, BUNDLED_BASE, BUNDLED_FLANGE, BUNDLED_URDF,
};

/// A scratch directory of this test binary (removed and recreated per test name).
fn scratch(name: &str) -> std::path::PathBuf {
    let d = std::env::temp_dir().join(format!("vjm-it-{}-bounded-{name}", std::process::id()));
    let _ = std::fs::remove_dir_all(&d);
    std::fs::create_dir_all(&d).unwrap();
    d
}

const ROBOT_TAG: &str = "<robot name=\"panda\">";

/// The bundled URDF with `levels` nested `<a>` elements inside `<robot>`, one per line.
fn nested_urdf(levels: usize) -> String {
    let deep = format!("{}{}", "<a>\n".repeat(levels), "</a>".repeat(levels));
    in_robot(&deep)
}

/// The bundled URDF with `xml` at the start of `<robot>`'s content.
fn in_robot(xml: &str) -> String {
    assert!(BUNDLED_URDF.contains(ROBOT_TAG));
    BUNDLED_URDF.replacen(ROBOT_TAG, &format!("{ROBOT_TAG}{xml}"), 1)
}

/// Runs `f` on a thread with a 256 kB stack: a check that recursed per level would overflow
/// it long before the parsers' 8 MB main stack, so the test proves the scan is linear.
fn on_small_stack<T: Send + 'static>(f: impl FnOnce() -> T + Send + 'static) -> T {
    std::thread::Builder::new()
        .stack_size(256 << 10)
        .spawn(f)
        .unwrap()
        .join()
        .unwrap()
}

#[test]
fn deeply_nested_urdf_is_refused_before_parsing() {
    for levels in [20_000, 100_000] {
        let xml = nested_urdf(levels);
        let err = on_small_stack(move || {
            SerialChain::from_urdf_str(&xml, BUNDLED_BASE, BUNDLED_FLANGE).unwrap_err()
        });
        match &err {
            VjmError::UrdfLimit {
                path: None,
                limit:
                    TextLimitError::TooDeep {
                        depth, limit, line, ..
                    },
            } => {
                // `<robot>` and the nested elements, the first on `<robot>`'s line.
                assert_eq!((*depth, *limit), (levels + 1, URDF_MAX_DEPTH), "{err}");
                let robot_line = BUNDLED_URDF[..BUNDLED_URDF.find(ROBOT_TAG).unwrap()]
                    .matches('\n')
                    .count()
                    + 1;
                assert_eq!(*line, robot_line + URDF_MAX_DEPTH - 1, "{err}");
            }
            other => panic!("expected UrdfLimit, got {other:?}"),
        }
        let msg = err.to_string();
        assert!(
            msg.contains(&format!("{} levels deep", levels + 1)) && msg.contains("256"),
            "{msg}"
        );
    }
    // From a file the message names it.
    let dir = scratch("urdf");
    let path = dir.join("deep.urdf");
    std::fs::write(&path, nested_urdf(20_000)).unwrap();
    let err = SerialChain::from_urdf_file(&path, BUNDLED_BASE, BUNDLED_FLANGE).unwrap_err();
    assert!(
        matches!(err, VjmError::UrdfLimit { path: Some(_), .. }),
        "{err:?}"
    );
    assert!(err.to_string().contains("deep.urdf"), "{err}");
    let _ = std::fs::remove_dir_all(&dir);
}

#[test]
fn nesting_up_to_the_limit_and_markup_in_comments_is_not_refused() {
    // At the limit the scan lets the text through (urdf-rs ignores the unknown elements).
    let xml = nested_urdf(URDF_MAX_DEPTH - 1);
    let chain = SerialChain::from_urdf_str(&xml, BUNDLED_BASE, BUNDLED_FLANGE).unwrap();
    assert_eq!(chain.n_joints(), 7);
    let err =
        SerialChain::from_urdf_str(&nested_urdf(URDF_MAX_DEPTH), BUNDLED_BASE, BUNDLED_FLANGE)
            .unwrap_err();
    assert!(matches!(err, VjmError::UrdfLimit { .. }), "{err:?}");
    // Markup inside a comment, a CDATA section, a processing instruction, an attribute value
    // or a DOCTYPE's internal subset is not nesting.
    let deep = "<a>".repeat(20_000);
    for wrapped in [
        format!("<!-- {deep} -->"),
        format!("<![CDATA[{deep}]]>"),
        format!("<?pi {deep}?>"),
    ] {
        let xml = in_robot(&wrapped);
        let chain = on_small_stack(move || {
            SerialChain::from_urdf_str(&xml, BUNDLED_BASE, BUNDLED_FLANGE).map(|c| c.n_joints())
        });
        assert_eq!(chain.unwrap(), 7);
    }
    let attr = BUNDLED_URDF.replacen("<robot", &format!("<robot note=\"{deep} />\""), 1);
    assert!(vjm::bounded::check_urdf_text(&attr).is_ok());
    let doctype =
        format!("<!DOCTYPE robot [ <!ENTITY x \"{deep}\"> <!ELEMENT a ANY> ]>\n{BUNDLED_URDF}");
    assert!(vjm::bounded::check_urdf_text(&doctype).is_ok());
    // Self-closing elements do not nest.
    assert!(vjm::bounded::check_urdf_text(&"<a/><b x='>'/>".repeat(50_000)).is_ok());
}

#[test]
fn oversized_urdf_is_refused_without_reading_it() {
    let big = format!(
        "{BUNDLED_URDF}<!--{}-->",
        " ".repeat(URDF_MAX_BYTES as usize)
    );
    let err = SerialChain::from_urdf_str(&big, BUNDLED_BASE, BUNDLED_FLANGE).unwrap_err();
    assert!(
        matches!(err, VjmError::UrdfLimit { limit: TextLimitError::TooLarge { limit, at_least: false, .. }, .. } if limit == URDF_MAX_BYTES),
        "{err:?}"
    );
    // A sparse file of 1 GB: refused from its size, not read.
    let dir = scratch("big-urdf");
    let path = dir.join("huge.urdf");
    std::fs::File::create(&path)
        .unwrap()
        .set_len(1 << 30)
        .unwrap();
    let err = SerialChain::from_urdf_file(&path, BUNDLED_BASE, BUNDLED_FLANGE).unwrap_err();
    let msg = err.to_string();
    assert!(
        msg.contains("huge.urdf") && msg.contains("1073741824 bytes"),
        "{msg}"
    );
    let _ = std::fs::remove_dir_all(&dir);
}

fn panda_model() -> (SerialChain, StiffnessModel) {
    let chain = SerialChain::bundled();
    let spec = CampaignSpec {
        n_poses: 12,
        seed: 9,
        ..Default::default()
    };
    let sm = crate::strategies::identified_model(&chain, &VirtualJointModel::extended(7), &spec);
    (chain, sm)
}

#[test]
fn deeply_nested_or_oversized_model_file_is_refused() {
    let (chain, sm) = panda_model();
    let deep = "[".repeat(200_000);
    let err = on_small_stack(move || StiffnessModel::from_json(&deep, "deep.json").unwrap_err());
    assert!(
        matches!(&err, ModelError::Limit { limit: TextLimitError::TooDeep { depth: 200_000, limit, line: 1, .. }, .. } if *limit == MODEL_FILE_MAX_DEPTH),
        "{err:?}"
    );
    assert!(err.to_string().contains("deep.json"), "{err}");
    // Brackets inside strings are text; a real file nests far less than the limit.
    let good = sm.to_json();
    let with_text = good.replacen(
        "\"created_by\": \"",
        &format!("\"created_by\": \"{}\\\"", "[".repeat(1000)),
        1,
    );
    assert!(vjm::bounded::check_model_file_text(&with_text).is_ok());
    assert!(StiffnessModel::from_json(&good, "m.json").is_ok());
    // A file above the size cap is refused from its size.
    let dir = scratch("big-model");
    let path = dir.join("huge.json");
    std::fs::File::create(&path)
        .unwrap()
        .set_len(MODEL_FILE_MAX_BYTES + 1)
        .unwrap();
    let err = StiffnessModel::load(&path, &chain).unwrap_err();
    assert!(
        matches!(
            err,
            ModelError::Limit {
                limit: TextLimitError::TooLarge { .. },
                ..
            }
        ),
        "{err:?}"
    );
    let path = dir.join("deep.json");
    std::fs::write(&path, "[".repeat(200_000)).unwrap();
    let err = StiffnessModel::load(&path, &chain).unwrap_err();
    assert!(matches!(err, ModelError::Limit { .. }), "{err:?}");
    let _ = std::fs::remove_dir_all(&dir);
}

/// The file text of `sm` with `edit` applied to its `model` and the content hash recomputed,
/// as a user who read the format's documentation could do.
fn forged(sm: &StiffnessModel, edit: impl FnOnce(&mut Value)) -> String {
    let mut doc: Value = serde_json::from_str(&sm.to_json()).unwrap();
    edit(&mut doc["model"]);
    let model: StiffnessModel = serde_json::from_value(doc["model"].clone()).unwrap();
    doc["content_sha256"] = Value::String(model.content_sha256());
    doc.to_string()
}

/// An edit of a model file's `model` object.
type Edit = Box<dyn FnOnce(&mut Value)>;

#[test]
fn impossible_values_are_refused_even_with_a_matching_hash() {
    let (chain, sm) = panda_model();
    // The forging itself keeps a file valid.
    let same = forged(&sm, |_| {});
    let back = StiffnessModel::from_json(&same, "same.json").unwrap();
    back.check_robot(&chain, "same.json").unwrap();
    let m = sm.springs().labels.len();
    assert!(sm.estimate().covariance.is_some());
    let cases: Vec<(&str, Edit)> = vec![
        (
            "estimate.covariance[3][3] is -1e-12, it must be ≥ 0",
            Box::new(|v: &mut Value| v["estimate"]["covariance"][3][3] = (-1e-12).into()),
        ),
        (
            "noise.noise_sigma[1] is -0.0001, it must be finite and > 0",
            Box::new(|v: &mut Value| v["noise"]["noise_sigma"][1] = (-1e-4).into()),
        ),
        (
            "noise.noise_sigma[0] is 0, it must be finite and > 0",
            Box::new(|v: &mut Value| v["noise"]["noise_sigma"][0] = 0.0.into()),
        ),
        (
            "noise.sigma2 is -1, it must be finite and ≥ 0",
            Box::new(|v: &mut Value| v["noise"]["sigma2"] = (-1.0).into()),
        ),
        (
            "estimate.column_scale[5] is 0, it must be finite and > 0",
            Box::new(|v: &mut Value| v["estimate"]["column_scale"][5] = 0.0.into()),
        ),
        (
            "identification.combinations[0].stderr is -1e-6, it must be finite and ≥ 0",
            Box::new(|v: &mut Value| {
                v["identification"]["combinations"][0]["stderr"] = (-1e-6).into()
            }),
        ),
        (
            "estimate.covariance is not symmetric: [0][2] is 1e300",
            Box::new(|v: &mut Value| v["estimate"]["covariance"][0][2] = 1e300.into()),
        ),
    ];
    for (expected, edit) in cases {
        let text = forged(&sm, edit);
        let err = StiffnessModel::from_json(&text, "forged.json");
        let err = match err {
            Err(e) => e,
            Ok(_) => panic!("accepted a file with {expected}"),
        };
        let msg = err.to_string();
        assert!(matches!(err, ModelError::Format { .. }), "{err:?}");
        assert!(
            msg.contains(expected) && msg.contains("forged.json"),
            "{msg}\nexpected: {expected}"
        );
    }
    // A covariance of the wrong shape names it.
    let text = forged(&sm, |v| {
        v["estimate"]["covariance"].as_array_mut().unwrap().pop();
    });
    let msg = StiffnessModel::from_json(&text, "f.json")
        .unwrap_err()
        .to_string();
    assert!(msg.contains(&format!("covariance is not {m}×{m}")), "{msg}");
}

#[test]
fn messages_quote_numbers_short() {
    let text = "q1,q2,fx,fy,fz,mx,my,mz,dx,dy,dz\n0.1,0.2,10,0,0,0,0,1,1e308,0,0\n";
    let err = Dataset::from_reader(text.as_bytes(), 2)
        .unwrap_err()
        .to_string();
    assert!(err.contains("1e308") && err.len() < 200, "{err}");
    let text = "q1,q2,fx,fy,fz,mx,my,mz,dx,dy,dz\n1e300,0.2,10,0,0,0,0,1,1e-4,0,0\n";
    let err = Dataset::from_reader(text.as_bytes(), 2)
        .unwrap_err()
        .to_string();
    assert!(err.contains("1e300") && err.len() < 300, "{err}");
    let xml = BUNDLED_URDF.replacen("lower=\"-2.8973\"", "lower=\"1e300\"", 1);
    assert_ne!(xml, BUNDLED_URDF);
    let err = SerialChain::from_urdf_str(&xml, BUNDLED_BASE, BUNDLED_FLANGE)
        .unwrap_err()
        .to_string();
    assert!(err.contains("1e300") && err.len() < 200, "{err}");
    let mut opts = IdentifyOptions::default();
    opts.noise_sigma = [-1e300, 1e-5, 1e-5, 1e-5, 1e-5, 1e-5];
    let chain = SerialChain::bundled();
    let q = vec![0.0; 7];
    let err = identify(
        &chain,
        &VirtualJointModel::traditional(7),
        Measurements::new(&q, &[1.0; 6], &[1e-4; 3]),
        &opts,
    )
    .unwrap_err()
    .to_string();
    assert!(err.contains("-1e300") && err.len() < 200, "{err}");
}
