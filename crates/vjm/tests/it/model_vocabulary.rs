//! The one model vocabulary: what `diagnose` prints, `VirtualJointModel::parse` reads back.

use vjm::diagnose::candidates::catalogue;
use vjm::diagnose::{diagnose, DiagnoseOptions};
use vjm::testbed::{simulate, CampaignSpec, Effect, TrueModel};
use vjm::{SerialChain, SpringAxis, VirtualJointModel};

#[test]
fn the_extended_model_diagnose_prints_is_read_back_as_its_springs() {
    let chain = SerialChain::bundled();
    let truth = TrueModel::nominal(7).with_effect(Effect::JointTilt {
        joint: 2,
        axis: SpringAxis::X,
        compliance: 6e-5,
    });
    let spec = CampaignSpec {
        seed: 4,
        ..Default::default()
    };
    let c = simulate(&chain, &truth, &spec).unwrap();
    let d = diagnose(&chain, &c.dataset, &DiagnoseOptions::default()).unwrap();
    let tilts: Vec<String> = d
        .findings
        .iter()
        .filter(|f| f.effect == "joint_tilt")
        .map(|f| format!("J{}{}", f.joint.unwrap(), f.axis.clone().unwrap()))
        .collect();
    assert!(!tilts.is_empty(), "{}", d.extended.model);
    let model = VirtualJointModel::parse(7, &d.extended.model).unwrap();
    let mut expected: Vec<String> = VirtualJointModel::traditional(7).labels();
    expected.extend(tilts);
    // Base → tip, [z, x, y] within a joint.
    expected.sort_by_key(|l| {
        (
            l[1..l.len() - 1].parse::<usize>().unwrap(),
            "zxy".find(&l[l.len() - 1..]),
        )
    });
    assert_eq!(model.labels(), expected, "{}", d.extended.model);
    // The baseline's name too, and a custom baseline's (printed as its springs).
    assert_eq!(
        VirtualJointModel::parse(7, &d.baseline.model).unwrap(),
        VirtualJointModel::traditional(7)
    );
    let custom = VirtualJointModel::parse(7, "J1z,J2z,J2x,J4z,J6z").unwrap();
    let d = diagnose(
        &chain,
        &c.dataset,
        &DiagnoseOptions {
            baseline: Some(custom.clone()),
            ..Default::default()
        },
    )
    .unwrap();
    assert_eq!(d.baseline.model, "J1z,J2z,J2x,J4z,J6z");
    assert_eq!(
        VirtualJointModel::parse(7, &d.baseline.model).unwrap(),
        custom
    );
}

#[test]
fn every_catalogue_label_is_a_spring_or_refused_by_name() {
    let all = vec![true; 21];
    let none = {
        let mut m = vec![false; 21];
        for j in 0..7 {
            m[3 * j] = true;
        }
        m
    };
    for in_model in [all, none] {
        for cand in catalogue(&in_model) {
            let label = cand.label();
            let spec = format!("traditional + {label}");
            match VirtualJointModel::parse(7, &spec) {
                Ok(m) => {
                    // A tilt is the spring J3x, a link translation the spring J3tx.
                    let t = match cand.effect() {
                        "joint_tilt" => "",
                        "link_translation" => "t",
                        other => panic!("{label}: {other} parsed as a spring"),
                    };
                    let spring =
                        format!("J{}{t}{}", cand.joint().unwrap() + 1, cand.axis().unwrap());
                    assert!(m.labels().contains(&spring), "{label}: {:?}", m.labels());
                    assert_eq!(m.n_params(), 8);
                }
                Err(e) => {
                    let e = e.to_string();
                    assert_ne!(cand.effect(), "joint_tilt", "{label}: {e}");
                    assert_ne!(cand.effect(), "link_translation", "{label}: {e}");
                    assert!(
                        e.contains(&label) && e.contains("not a virtual spring"),
                        "{e}"
                    );
                }
            }
        }
    }
}

#[test]
fn the_union_is_ordered_and_named_and_bad_terms_are_named() {
    let m = VirtualJointModel::parse(7, "J3x + J1z, traditional").unwrap();
    assert_eq!(m.n_params(), 8);
    assert_eq!(m.labels()[..4], ["J1z", "J2z", "J3z", "J3x"]);
    assert_eq!(m.name(), "custom");
    assert_eq!(
        VirtualJointModel::parse(7, " traditional ").unwrap().name(),
        "traditional"
    );
    assert_eq!(
        VirtualJointModel::parse(7, "extended + joint_tilt(J2y)").unwrap(),
        VirtualJointModel::extended(7)
    );
    assert_eq!(
        VirtualJointModel::parse(7, "J1z,J1z").unwrap().n_params(),
        1
    );
    for (spec, words) in [
        ("", "empty term"),
        ("traditional +", "empty term"),
        ("J8z", "joint 1..7"),
        ("J3q", "not a spring label"),
        ("fancy", "unknown model `fancy`"),
        ("joint_tilt(J3z)", "not z"),
        ("joint_tilt(J3x", "unclosed"),
        ("joint_twist(J3x)", "unknown model `joint_twist(J3x)`"),
        ("link_translation(J4tz)", "without `t`"),
        ("mount_translation", "a compliance of the mount"),
    ] {
        let e = VirtualJointModel::parse(7, spec).unwrap_err().to_string();
        assert!(e.contains(words), "{spec:?}: {e}");
    }
}
