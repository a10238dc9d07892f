//! Where a model file finds its URDF: the absolute path recorded when the model was built,
//! `urdf_relative` (relative to the model file's folder) when the folder moved with its URDF,
//! the path as given in older files, and the content hash deciding between candidates.

use std::path::{Path, PathBuf};

use vjm::stiffness_model::RecordedRobot;
use vjm::testbed::CampaignSpec;
use vjm::{ModelError, SerialChain, StiffnessModel, VirtualJointModel, BUNDLED_URDF};

use crate::strategies::identified_model;

/// A scratch directory of this test binary (removed and recreated per test name).
fn scratch(name: &str) -> PathBuf {
    let d = std::env::temp_dir().join(format!("vjm-it-{}-urdfpath-{name}", std::process::id()));
    let _ = std::fs::remove_dir_all(&d);
    std::fs::create_dir_all(&d).unwrap();
    d
}

/// The model of a small noise-free campaign on the chain read from `urdf` (the bundled
/// Panda's text in a file of the test's own).
fn model_of(urdf: &Path) -> (SerialChain, StiffnessModel) {
    let chain = SerialChain::from_urdf_file(urdf, "panda_link0", "panda_link8").unwrap();
    let sm = identified_model(
        &chain,
        &VirtualJointModel::traditional(7),
        &small_campaign(),
    );
    (chain, sm)
}

/// A small noise-free campaign: 8 poses, seed 5.
fn small_campaign() -> CampaignSpec {
    CampaignSpec {
        n_poses: 8,
        seed: 5,
        noise: false,
        ..Default::default()
    }
}

fn recorded(model_file: &Path) -> RecordedRobot {
    StiffnessModel::recorded_robot(model_file).expect("a readable robot record")
}

fn file_field(model_file: &Path, field: &str) -> serde_json::Value {
    let doc: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(model_file).unwrap()).unwrap();
    doc[field].clone()
}

/// Lexically the same file (`a/m/../arm.urdf` is `a/arm.urdf`).
fn same_place(a: &Path, b: &Path) -> bool {
    let norm = |p: &Path| -> PathBuf {
        let mut out = PathBuf::new();
        for c in p.components() {
            match c {
                std::path::Component::ParentDir => {
                    out.pop();
                }
                std::path::Component::CurDir => {}
                other => out.push(other),
            }
        }
        out
    };
    norm(a) == norm(b)
}

#[test]
fn the_urdf_is_recorded_absolute_and_relative_to_the_model_file() {
    let dir = scratch("recorded");
    std::fs::create_dir_all(dir.join("models")).unwrap();
    std::fs::create_dir_all(dir.join("sub")).unwrap();
    std::fs::write(dir.join("arm.urdf"), BUNDLED_URDF).unwrap();
    // Given with a detour: recorded normalised, as os.path.abspath would.
    let (chain, sm) = model_of(&dir.join("sub/../arm.urdf"));
    let urdf = sm.robot().urdf.clone().unwrap();
    assert_eq!(Path::new(&urdf), dir.join("arm.urdf"), "{urdf}");
    let path = dir.join("models/m.json");
    sm.save(&path).unwrap();
    assert_eq!(file_field(&path, "urdf_relative"), "../arm.urdf");
    // The location is not part of the model: it loads equal, with the same hash, and the text
    // without a path has no urdf_relative.
    let back = StiffnessModel::load(&path, &chain).unwrap();
    assert_eq!(back, sm);
    assert_eq!(
        file_field(&path, "content_sha256").as_str(),
        Some(sm.content_sha256().as_str())
    );
    assert!(!sm.to_json().contains("urdf_relative"));
    assert!(sm
        .to_json_at(dir.join("m.json"))
        .contains("\"urdf_relative\": \"arm.urdf\""));
    let r = recorded(&path);
    assert_eq!(r.urdf_relative.as_deref(), Some("../arm.urdf"));
    assert_eq!(r.tried[0], dir.join("arm.urdf"));
    assert_eq!(r.urdf.as_deref(), Some(dir.join("arm.urdf").as_path()));
    assert_eq!(
        StiffnessModel::robot_of_file(&path).as_ref(),
        Some(&r.record)
    );
    let _ = std::fs::remove_dir_all(&dir);
}

#[test]
fn a_folder_moved_with_its_urdf_still_finds_it_and_a_changed_urdf_is_refused() {
    let dir = scratch("moved");
    let (old, new) = (dir.join("old"), dir.join("new"));
    std::fs::create_dir_all(old.join("models")).unwrap();
    std::fs::write(old.join("arm.urdf"), BUNDLED_URDF).unwrap();
    let (_, sm) = model_of(&old.join("arm.urdf"));
    sm.save(old.join("models/m.json")).unwrap();
    std::fs::rename(&old, &new).unwrap();
    let path = new.join("models/m.json");
    let r = recorded(&path);
    assert_eq!(r.tried.len(), 2, "{:?}", r.tried);
    assert_eq!(r.tried[0], old.join("arm.urdf"));
    let found = r.urdf.clone().expect("found through urdf_relative");
    assert!(same_place(&found, &new.join("arm.urdf")), "{found:?}");
    let chain = SerialChain::from_urdf_file(&found, &r.record.base, &r.record.tip).unwrap();
    StiffnessModel::load(&path, &chain).unwrap();

    // A changed URDF is still found (it is the file named) and refused by its content hash.
    std::fs::write(
        new.join("arm.urdf"),
        format!("{BUNDLED_URDF}\n<!-- edited -->\n"),
    )
    .unwrap();
    let found = recorded(&path).urdf.unwrap();
    let chain = SerialChain::from_urdf_file(&found, "panda_link0", "panda_link8").unwrap();
    let err = StiffnessModel::load(&path, &chain).unwrap_err();
    assert!(
        matches!(err, ModelError::OtherRobot { what, .. } if what.contains("URDF content")),
        "{err}"
    );

    // Gone from everywhere: nothing found, every place tried named.
    std::fs::remove_file(new.join("arm.urdf")).unwrap();
    let r = recorded(&path);
    assert!(r.urdf.is_none());
    assert_eq!(r.tried.len(), 2);
    let _ = std::fs::remove_dir_all(&dir);
}

#[test]
fn the_copy_with_the_recorded_content_wins_over_a_changed_original() {
    let dir = scratch("copy");
    let (a, b) = (dir.join("a"), dir.join("b"));
    std::fs::create_dir_all(a.join("m")).unwrap();
    std::fs::create_dir_all(b.join("m")).unwrap();
    std::fs::write(a.join("arm.urdf"), BUNDLED_URDF).unwrap();
    let (_, sm) = model_of(&a.join("arm.urdf"));
    sm.save(a.join("m/model.json")).unwrap();
    // The project is copied to b; then the original URDF is edited.
    std::fs::write(b.join("arm.urdf"), BUNDLED_URDF).unwrap();
    std::fs::copy(a.join("m/model.json"), b.join("m/model.json")).unwrap();
    std::fs::write(a.join("arm.urdf"), format!("{BUNDLED_URDF}<!-- x -->")).unwrap();
    let r = recorded(&b.join("m/model.json"));
    assert_eq!(r.tried[0], a.join("arm.urdf"));
    assert!(
        same_place(r.urdf.as_ref().unwrap(), &b.join("arm.urdf")),
        "{r:?}"
    );
    // Without a copy of the right content, the first existing file is the one named.
    let r = recorded(&a.join("m/model.json"));
    assert_eq!(r.urdf.as_deref(), Some(a.join("arm.urdf").as_path()));
    let _ = std::fs::remove_dir_all(&dir);
}

#[test]
fn an_older_file_with_a_relative_path_finds_the_urdf_beside_the_model_file() {
    let dir = scratch("older");
    // A name that the current folder (the test's) does not hold.
    let name = format!("vjm-it-older-{}.urdf", std::process::id());
    std::fs::write(dir.join(&name), BUNDLED_URDF).unwrap();
    let (chain, sm) = model_of(&dir.join(&name));
    // An older file: the URDF as given (relative), no urdf_relative; a valid content hash.
    let mut doc: serde_json::Value = serde_json::from_str(&sm.to_json()).unwrap();
    doc["model"]["robot"]["urdf"] = serde_json::Value::String(name.clone());
    let older: StiffnessModel = serde_json::from_value(doc["model"].take()).unwrap();
    let path = dir.join("m.json");
    std::fs::write(&path, older.to_json()).unwrap();
    assert!(file_field(&path, "urdf_relative").is_null());
    StiffnessModel::load(&path, &chain).unwrap();
    let r = recorded(&path);
    assert!(r.urdf_relative.is_none());
    assert_eq!(r.tried, vec![PathBuf::from(&name), dir.join(&name)]);
    assert_eq!(r.urdf.as_ref(), Some(&dir.join(&name)), "{r:?}");
    let _ = std::fs::remove_dir_all(&dir);
}

#[test]
fn the_bundled_arm_and_urdf_text_record_no_place() {
    let dir = scratch("bundled");
    let chain = SerialChain::bundled();
    let sm = identified_model(
        &chain,
        &VirtualJointModel::traditional(7),
        &small_campaign(),
    );
    let path = dir.join("m.json");
    sm.save(&path).unwrap();
    assert!(file_field(&path, "urdf_relative").is_null());
    let r = recorded(&path);
    assert_eq!(r.record.urdf.as_deref(), Some(vjm::BUNDLED_URDF_PATH));
    assert!(r.tried.is_empty() && r.urdf.is_none());
    let _ = std::fs::remove_dir_all(&dir);
}
