//! The harmonic excitation f(t) = sum_h (f_h^c cos(h W t) + f_h^s sin(h W t)) in the reduced
//! coordinates (N for SI models; DESIGN §10.3). h is the harmonic of the response the force
//! drives (1 for a force at the excitation frequency W; an engine-order pattern with several
//! harmonics is several entries). A load on a mesh group reaches the reduced coordinates as
//! T^T f (the modal crate's static correction makes it exact in the static limit).

use crate::error::ForcedError;

/// One harmonic of the excitation.
#[derive(Clone, Debug, PartialEq)]
pub struct HarmonicLoad {
    /// Harmonic h >= 1 of the response frequency W.
    pub harmonic: usize,
    /// Cosine part f_h^c (n values, N).
    pub cos: Vec<f64>,
    /// Sine part f_h^s (n values, N).
    pub sin: Vec<f64>,
}

/// The whole excitation: its harmonics (each h at most once).
#[derive(Clone, Debug, PartialEq)]
pub struct Load {
    /// The harmonics of the excitation.
    pub harmonics: Vec<HarmonicLoad>,
}

impl Load {
    /// A cosine force `shape` at the fundamental (h = 1).
    pub fn fundamental(shape: Vec<f64>) -> Self {
        let n = shape.len();
        Self {
            harmonics: vec![HarmonicLoad {
                harmonic: 1,
                cos: shape,
                sin: vec![0.0; n],
            }],
        }
    }

    /// The same load times `level`.
    pub fn scaled(&self, level: f64) -> Self {
        let scale = |v: &[f64]| v.iter().map(|x| x * level).collect();
        Self {
            harmonics: self
                .harmonics
                .iter()
                .map(|h| HarmonicLoad {
                    harmonic: h.harmonic,
                    cos: scale(&h.cos),
                    sin: scale(&h.sin),
                })
                .collect(),
        }
    }

    /// The same load seen from a time origin advanced by theta = W tau (rad): harmonic h's
    /// cos h(theta' + theta) and sin h(theta' + theta) expanded in theta', as
    /// `orbit_origin::advanced_orbit` turns the orbit.
    pub fn advanced(&self, theta: f64) -> Self {
        Self {
            harmonics: (self.harmonics.iter())
                .map(|h| {
                    let (s, c) = (h.harmonic as f64 * theta).sin_cos();
                    HarmonicLoad {
                        harmonic: h.harmonic,
                        cos: h
                            .cos
                            .iter()
                            .zip(&h.sin)
                            .map(|(a, b)| a * c + b * s)
                            .collect(),
                        sin: h
                            .cos
                            .iter()
                            .zip(&h.sin)
                            .map(|(a, b)| b * c - a * s)
                            .collect(),
                    }
                })
                .collect(),
        }
    }

    /// Checks sizes (n values per part), 1 <= h <= N, each h once, finite values and a nonzero
    /// load.
    pub fn validate(&self, n: usize, highest: usize) -> Result<(), ForcedError> {
        self.validate_shape(n, highest)?;
        let total: f64 = self
            .harmonics
            .iter()
            .flat_map(|h| h.cos.iter().chain(&h.sin))
            .map(|x| x.abs())
            .sum();
        if total == 0.0 {
            return Err(ForcedError::Load {
                what: "harmonics".into(),
                detail: "every value is zero; expected a nonzero force".into(),
            });
        }
        Ok(())
    }

    /// [`Load::validate`] without the nonzero force: a casing distortion alone excites the
    /// structure with every value of its load zero (DESIGN §10.11).
    pub fn validate_shape(&self, n: usize, highest: usize) -> Result<(), ForcedError> {
        let err = |what: String, detail: String| Err(ForcedError::Load { what, detail });
        if self.harmonics.is_empty() {
            return err(
                "harmonics".into(),
                "no harmonic given; expected at least one".into(),
            );
        }
        let mut seen = vec![false; highest + 1];
        for hl in &self.harmonics {
            let h = hl.harmonic;
            if h == 0 || h > highest {
                return err(
                    format!("harmonic {h}"),
                    format!("expected 1 <= h <= N = {highest} (the highest harmonic kept)"),
                );
            }
            if std::mem::replace(&mut seen[h], true) {
                return err(format!("harmonic {h}"), "given twice".into());
            }
            for (part, v) in [("cos", &hl.cos), ("sin", &hl.sin)] {
                if v.len() != n {
                    return err(
                        format!("harmonic {h} {part}"),
                        format!(
                            "{} values, expected {n} (one per reduced coordinate)",
                            v.len()
                        ),
                    );
                }
                if let Some(i) = v.iter().position(|x| !x.is_finite()) {
                    return err(
                        format!("harmonic {h} {part}[{i}]"),
                        format!("{} is not finite", v[i]),
                    );
                }
            }
        }
        Ok(())
    }

    /// The same load on the basis of a fundamental `k` times lower: harmonic h of W becomes
    /// harmonic k h of W / k (a speed sweep whose orbit's fundamental is gcd(e, n) Omega
    /// instead of e Omega, DESIGN §10.11).
    pub fn on_lower_fundamental(&self, k: usize) -> Self {
        Self {
            harmonics: self
                .harmonics
                .iter()
                .map(|h| HarmonicLoad {
                    harmonic: h.harmonic * k,
                    ..h.clone()
                })
                .collect(),
        }
    }

    /// The cosine and sine parts of harmonic `h` (zeros when the load has none there).
    pub fn at(&self, h: usize, n: usize) -> (Vec<f64>, Vec<f64>) {
        self.harmonics
            .iter()
            .find(|x| x.harmonic == h)
            .map(|x| (x.cos.clone(), x.sin.clone()))
            .unwrap_or_else(|| (vec![0.0; n], vec![0.0; n]))
    }
}
