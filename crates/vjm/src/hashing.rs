//! SHA-256 fingerprints: of file contents (URDF, measurement files) and of a chain's kinematics,
//! so that a saved stiffness model can tell whether it is used with the robot it describes.

use sha2::{Digest, Sha256};

use crate::chain::SerialChain;

/// SHA-256 of `bytes`, lowercase hex (64 characters).
pub fn sha256_hex(bytes: &[u8]) -> String {
    hex(&Sha256::digest(bytes))
}

/// SHA-256 of everything `source` yields, lowercase hex; read in 1 MiB pieces, so a
/// measurement file of any size is hashed in bounded memory (no copy of the file).
pub fn sha256_hex_reader(mut source: impl std::io::Read) -> std::io::Result<String> {
    let mut h = Sha256::new();
    let mut buf = vec![0u8; 1 << 20];
    loop {
        match source.read(&mut buf) {
            Ok(0) => return Ok(hex(&h.finalize())),
            Ok(n) => h.update(&buf[..n]),
            Err(e) if e.kind() == std::io::ErrorKind::Interrupted => {}
            Err(e) => return Err(e),
        }
    }
}

/// Lowercase hex of a digest.
pub(crate) fn hex(digest: &[u8]) -> String {
    const DIGITS: &[u8; 16] = b"0123456789abcdef";
    let mut s = String::with_capacity(2 * digest.len());
    for b in digest {
        s.push(DIGITS[(b >> 4) as usize] as char);
        s.push(DIGITS[(b & 0xf) as usize] as char);
    }
    s
}

/// SHA-256 over everything of `chain` that a deflection prediction depends on: base and tip
/// names, and per actuated joint its name, origin (translation and unit quaternion) and axis,
/// then the tip offset; numbers as their IEEE-754 bits, so any change is seen. Joint limits are
/// left out (they do not change a prediction). Chains built without a URDF text (which have no
/// [`UrdfSource`](crate::UrdfSource)) are told apart by this alone.
pub fn kinematics_sha256(chain: &SerialChain) -> String {
    let mut h = Sha256::new();
    let mut text = |s: &str| {
        h.update((s.len() as u64).to_le_bytes());
        h.update(s.as_bytes());
    };
    text(chain.base_link());
    text(chain.tip_link());
    let mut numbers: Vec<f64> = Vec::with_capacity(10 * chain.n_joints() + 7);
    let mut names = Vec::with_capacity(chain.n_joints());
    let push_pose = |v: &mut Vec<f64>, p: &nalgebra::Isometry3<f64>| {
        v.extend(p.translation.vector.iter());
        v.extend(p.rotation.coords.iter());
    };
    for j in chain.joints() {
        names.push(j.name());
        push_pose(&mut numbers, j.origin());
        numbers.extend(j.axis().iter());
    }
    push_pose(&mut numbers, chain.tip_offset());
    for name in names {
        text(name);
    }
    for v in numbers {
        h.update(v.to_bits().to_le_bytes());
    }
    hex(&h.finalize())
}

/// SHA-256 over the chain's [`MassModel`](crate::gravity::MassModel): the number of bodies,
/// then per actuated joint (base → tip) its body's mass and centre of mass (child frame); numbers
/// as their IEEE-754 bits. What a model identified under gravity assumed the arm weighs; an
/// error when the chain has no masses (naming the link without `<inertial>`).
pub fn inertials_sha256(chain: &SerialChain) -> Result<String, crate::VjmError> {
    let masses = chain.mass_model()?;
    let mut h = Sha256::new();
    h.update((masses.bodies().len() as u64).to_le_bytes());
    for b in masses.bodies() {
        for v in std::iter::once(b.mass).chain(b.com.iter().copied()) {
            h.update(v.to_bits().to_le_bytes());
        }
    }
    Ok(hex(&h.finalize()))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn sha256_of_known_strings() {
        // FIPS 180-2 test vectors.
        assert_eq!(
            sha256_hex(b"abc"),
            "ba7816bf8f01cfea414140de5dae2223b00361a396177a9cb410ff61f20015ad"
        );
        assert_eq!(
            sha256_hex(b""),
            "e3b0c44298fc1c149afbf4c8996fb92427ae41e4649b934ca495991b7852b855"
        );
    }

    /// FIPS 180-2's million-`a` vector, read in pieces that do not line up with the 1 MiB
    /// buffer or the 64-byte blocks (a reader that returns at most 777 bytes per call).
    #[test]
    fn sha256_of_a_stream_is_that_of_its_bytes() {
        struct Trickle(std::io::Repeat, usize);
        impl std::io::Read for Trickle {
            fn read(&mut self, buf: &mut [u8]) -> std::io::Result<usize> {
                let n = buf.len().min(777).min(self.1);
                self.1 -= n;
                self.0.read(&mut buf[..n])
            }
        }
        let million_a = Trickle(std::io::repeat(b'a'), 1_000_000);
        assert_eq!(
            sha256_hex_reader(million_a).unwrap(),
            "cdc76e5c9914fb9281a1c7e284d73e67f1809a48a497200e046d39ccc7112cd0"
        );
        let two_mib = vec![7u8; 2 << 20];
        assert_eq!(
            sha256_hex_reader(&two_mib[..]).unwrap(),
            sha256_hex(&two_mib)
        );
    }

    #[test]
    fn kinematics_hash_sees_the_tip() {
        let a = SerialChain::bundled();
        let b = SerialChain::bundled_with_tip(crate::BUNDLED_TCP).unwrap();
        assert_ne!(kinematics_sha256(&a), kinematics_sha256(&b));
        assert_eq!(
            kinematics_sha256(&a),
            kinematics_sha256(&SerialChain::bundled())
        );
    }
}
