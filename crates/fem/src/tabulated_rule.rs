//! Quadrature rules with the shape functions tabulated at their points.

use crate::quadrature::TetRule;
use crate::shape;
use crate::tet_kind::TetKind;

/// A quadrature rule with the shape functions and their reference gradients tabulated at its
/// points for one element kind.
#[derive(Clone, Debug)]
pub struct TabulatedRule {
    /// Element kind the tables are for.
    pub kind: TetKind,
    /// The rule.
    pub rule: TetRule,
    /// N_a at point q: `values[q * npe + a]`.
    pub values: Vec<f64>,
    /// dN_a/dxi at point q: `gradients[q * npe + a]`.
    pub gradients: Vec<[f64; 3]>,
    /// S = sum_a dN_a/dxi (dN_a/dxi)^T at point q (for the trace functional).
    pub gradient_gram: Vec<[[f64; 3]; 3]>,
}

impl TabulatedRule {
    /// Tabulates the shape functions of `kind` at the points of `rule`.
    pub fn new(kind: TetKind, rule: TetRule) -> Self {
        let npe = kind.nodes_per_element();
        let mut values = vec![0.0; rule.len() * npe];
        let mut gradients = vec![[0.0; 3]; rule.len() * npe];
        let mut gradient_gram = vec![[[0.0; 3]; 3]; rule.len()];
        for (q, &p) in rule.points.iter().enumerate() {
            shape::values_into(kind, p, &mut values[q * npe..(q + 1) * npe]);
            let g = &mut gradients[q * npe..(q + 1) * npe];
            shape::gradients_into(kind, p, g);
            for ga in g.iter() {
                for i in 0..3 {
                    for j in 0..3 {
                        gradient_gram[q][i][j] += ga[i] * ga[j];
                    }
                }
            }
        }
        TabulatedRule {
            kind,
            rule,
            values,
            gradients,
            gradient_gram,
        }
    }
}
