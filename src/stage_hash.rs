//! The hash of a stage's inputs (make-like reruns of `nlmodes run`, `run` and `forced_stage`).

/// FNV-1a, 64 bit: a stable hash of stage inputs (stable across Rust versions, unlike `DefaultHasher`).
pub fn fnv1a(parts: &[&[u8]]) -> String {
    let mut h: u64 = 0xcbf29ce484222325;
    for p in parts {
        for &b in p.iter().chain(&[0xff]) {
            h ^= b as u64;
            h = h.wrapping_mul(0x100000001b3);
        }
    }
    format!("{h:016x}")
}
