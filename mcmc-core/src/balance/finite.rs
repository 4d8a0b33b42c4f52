//! Exact checks on finite state spaces: build the transition matrix of a kernel by enumerating
//! every outcome (through the same ratio and acceptance code the sampler runs) and verify detailed
//! balance `π_x P_xy = π_y P_yx`, stationarity `πP = π`, and irreducibility.

use super::CheckReport;
use crate::kernel::acceptance;
use crate::{ChainRng, Family, Kernel, McmcError, Proposal, Proposed, Target};
use crate::{Outcome, rng::stream};

/// A dense row-stochastic matrix `P[x][y]` over states `0..n`.
#[derive(Clone, Debug, PartialEq)]
pub struct TransitionMatrix {
    n: usize,
    p: Vec<f64>,
}

impl TransitionMatrix {
    /// The zero matrix.
    pub fn zeros(n: usize) -> Self {
        Self {
            n,
            p: vec![0.0; n * n],
        }
    }

    /// The identity (the kernel that never moves).
    pub fn identity(n: usize) -> Self {
        let mut m = Self::zeros(n);
        for i in 0..n {
            m.p[i * n + i] = 1.0;
        }
        m
    }

    /// Build from rows of `(to, probability)` entries (repeated targets add up).
    pub fn from_rows(n: usize, row: impl Fn(usize) -> Vec<(usize, f64)>) -> Self {
        let mut m = Self::zeros(n);
        for x in 0..n {
            for (y, pr) in row(x) {
                m.p[x * n + y] += pr;
            }
        }
        m
    }

    /// Number of states.
    pub fn len(&self) -> usize {
        self.n
    }

    /// Whether the matrix has no states.
    pub fn is_empty(&self) -> bool {
        self.n == 0
    }

    /// `P[x][y]`.
    pub fn get(&self, x: usize, y: usize) -> f64 {
        self.p[x * self.n + y]
    }

    /// The kernel "first `self`, then `next`" (matrix product).
    pub fn then(&self, next: &TransitionMatrix) -> TransitionMatrix {
        let n = self.n;
        let mut out = Self::zeros(n);
        for i in 0..n {
            for k in 0..n {
                let a = self.p[i * n + k];
                if a == 0.0 {
                    continue;
                }
                for j in 0..n {
                    out.p[i * n + j] += a * next.p[k * n + j];
                }
            }
        }
        out
    }

    /// The random-scan mixture `w·self + (1−w)·other`.
    pub fn mix(&self, w: f64, other: &TransitionMatrix) -> TransitionMatrix {
        TransitionMatrix {
            n: self.n,
            p: self
                .p
                .iter()
                .zip(&other.p)
                .map(|(a, b)| w * a + (1.0 - w) * b)
                .collect(),
        }
    }

    /// Largest deviation of a row sum from 1.
    pub fn row_sum_error(&self) -> f64 {
        (0..self.n)
            .map(|i| (self.p[i * self.n..(i + 1) * self.n].iter().sum::<f64>() - 1.0).abs())
            .fold(0.0, f64::max)
    }

    /// Largest `|π_x P_xy − π_y P_yx|` for a normalised `pi`.
    pub fn detailed_balance_error(&self, pi: &[f64]) -> f64 {
        let n = self.n;
        let mut worst = 0.0f64;
        for x in 0..n {
            for y in x + 1..n {
                worst = worst.max((pi[x] * self.p[x * n + y] - pi[y] * self.p[y * n + x]).abs());
            }
        }
        worst
    }

    /// Largest `|(πP)_y − π_y|`.
    pub fn stationarity_error(&self, pi: &[f64]) -> f64 {
        let n = self.n;
        (0..n)
            .map(|y| ((0..n).map(|x| pi[x] * self.p[x * n + y]).sum::<f64>() - pi[y]).abs())
            .fold(0.0, f64::max)
    }

    /// Whether every state with positive `pi` reaches every other such state (strong connectivity
    /// of the graph of positive transitions restricted to the support).
    pub fn is_irreducible(&self, pi: &[f64]) -> bool {
        let n = self.n;
        let support: Vec<usize> = (0..n).filter(|&i| pi[i] > 0.0).collect();
        let Some(&root) = support.first() else {
            return false;
        };
        let reach = |forward: bool| {
            let mut seen = vec![false; n];
            let mut stack = vec![root];
            seen[root] = true;
            while let Some(i) = stack.pop() {
                for (j, s) in seen.iter_mut().enumerate() {
                    let p = if forward {
                        self.p[i * n + j]
                    } else {
                        self.p[j * n + i]
                    };
                    if p > 0.0 && !*s {
                        *s = true;
                        stack.push(j);
                    }
                }
            }
            seen
        };
        let (f, b) = (reach(true), reach(false));
        support.iter().all(|&i| f[i] && b[i])
    }

    /// Run all three checks against `pi` (normalised here) with absolute tolerance `tol`.
    pub fn check(&self, pi: &[f64], tol: f64, require_reversible: bool) -> CheckReport {
        let z: f64 = pi.iter().sum();
        let pi: Vec<f64> = pi.iter().map(|p| p / z).collect();
        let rows = self.row_sum_error();
        let db = self.detailed_balance_error(&pi);
        let st = self.stationarity_error(&pi);
        let irr = self.is_irreducible(&pi);
        let worst = if require_reversible {
            rows.max(db).max(st)
        } else {
            rows.max(st)
        };
        CheckReport {
            check: "finite-space exact balance",
            passed: worst <= tol && irr,
            statistic: worst,
            threshold: tol,
            detail: format!(
                "row sums {rows:.2e}, detailed balance {db:.2e}, stationarity {st:.2e}, irreducible {irr}"
            ),
        }
    }
}

/// Normalised `π` of a target over `0..n`.
pub fn normalized_density<T: Target<usize>>(target: &T, n: usize) -> Vec<f64> {
    let w: Vec<f64> = (0..n).map(|x| target.ln_density(&x).exp()).collect();
    let z: f64 = w.iter().sum();
    w.into_iter().map(|v| v / z).collect()
}

/// The exact transition matrix of the Metropolis–Hastings kernel of `target` and `proposal` on
/// `0..n`, built from [`Proposal::outcomes`] and the kernel's own acceptance function.
pub fn mh_matrix<T: Target<usize>, P: Proposal<usize>>(
    target: &T,
    proposal: &P,
    n: usize,
) -> Result<TransitionMatrix, McmcError> {
    let mut m = TransitionMatrix::zeros(n);
    for x in 0..n {
        let outs = proposal
            .outcomes(&x)
            .ok_or_else(|| McmcError::Check("the proposal cannot enumerate its outcomes".into()))?;
        let lx = target.ln_density(&x);
        let mut stay = 1.0;
        for o in outs {
            if o.state >= n {
                return Err(McmcError::Check(format!(
                    "outcome {} outside 0..{n}",
                    o.state
                )));
            }
            let a = acceptance(lx, target.ln_density(&o.state), o.proposed.ln_ratio).0;
            m.p[x * n + o.state] += o.probability * a;
            stay -= o.probability * a;
        }
        m.p[x * n + x] += stay;
    }
    Ok(m)
}

/// A proposal on `0..n` given by explicit rows of `(to, probability)`. It reports the exact ratio
/// `ln q(x|y) − ln q(y|x)` unless built with [`TableProposal::treated_as_symmetric`] (a deliberately
/// broken variant for testing the checks).
#[derive(Clone, Debug)]
pub struct TableProposal {
    rows: Vec<Vec<(usize, f64)>>,
    symmetric_report: bool,
}

impl TableProposal {
    /// A proposal with the given rows; each row must sum to 1.
    pub fn new(rows: Vec<Vec<(usize, f64)>>) -> Result<Self, McmcError> {
        for (i, r) in rows.iter().enumerate() {
            let s: f64 = r.iter().map(|e| e.1).sum();
            if (s - 1.0).abs() > 1e-9 || r.iter().any(|e| e.0 >= rows.len() || e.1 < 0.0) {
                return Err(McmcError::InvalidParameter {
                    name: "rows",
                    reason: format!("row {i} is not a probability vector over the states"),
                });
            }
        }
        Ok(Self {
            rows,
            symmetric_report: false,
        })
    }

    /// The same proposal reporting a zero ratio whatever its asymmetry (broken on purpose).
    pub fn treated_as_symmetric(mut self) -> Self {
        self.symmetric_report = true;
        self
    }

    fn q(&self, x: usize, y: usize) -> f64 {
        self.rows[x].iter().filter(|e| e.0 == y).map(|e| e.1).sum()
    }
}

impl Proposal<usize> for TableProposal {
    fn propose(&self, x: &usize, y: &mut usize, rng: &mut ChainRng) -> Proposed {
        let mut u = crate::rng::uniform(rng);
        let row = &self.rows[*x];
        *y = row.last().map(|e| e.0).unwrap_or(*x);
        for &(to, p) in row {
            if u < p {
                *y = to;
                break;
            }
            u -= p;
        }
        self.report(*x, *y)
    }

    fn ln_transition_density(&self, from: &usize, to: &usize) -> Option<f64> {
        Some(self.q(*from, *to).ln())
    }

    fn outcomes(&self, x: &usize) -> Option<Vec<Outcome<usize>>> {
        Some(
            self.rows[*x]
                .iter()
                .map(|&(to, p)| Outcome {
                    state: to,
                    probability: p,
                    proposed: self.report(*x, to),
                })
                .collect(),
        )
    }

    fn kinds(&self) -> Vec<String> {
        vec!["table".into()]
    }
}

impl TableProposal {
    fn report(&self, x: usize, y: usize) -> Proposed {
        if self.symmetric_report {
            Proposed::SYMMETRIC
        } else {
            Proposed::with_ratio(self.q(y, x).ln() - self.q(x, y).ln())
        }
    }
}

/// Index of a tuple of `levels` states in `0..n` (mixed radix, level 0 least significant).
pub fn tuple_index(states: &[usize], n: usize) -> usize {
    states.iter().rev().fold(0, |acc, &s| acc * n + s)
}

/// The tuple of an index (inverse of [`tuple_index`]).
pub fn tuple_of(mut index: usize, n: usize, levels: usize) -> Vec<usize> {
    (0..levels)
        .map(|_| {
            let s = index % n;
            index /= n;
            s
        })
        .collect()
}

/// The exact matrix over tuples `(x_0, …, x_{K-1})` of one swap of the pair `(k, k+1)` of a replica
/// exchange over a family on `0..n`, computed by calling
/// [`crate::tempering::ReplicaExchange::swap_candidates`] on every tuple. Transfers must be
/// deterministic for this enumeration to be exact.
pub fn swap_matrix<F, K>(
    re: &mut crate::tempering::ReplicaExchange<usize, F, K>,
    n: usize,
    k: usize,
) -> TransitionMatrix
where
    F: Family<usize>,
    K: Kernel<usize>,
{
    let levels = re.levels();
    let size = n.pow(levels as u32);
    let mut m = TransitionMatrix::zeros(size);
    let mut rng = stream(0, 0);
    for idx in 0..size {
        let t = tuple_of(idx, n, levels);
        for (l, c) in re.chains.iter_mut().enumerate() {
            c.state = t[l];
            c.ln_density = re.family.ln_density(l, &mut c.state);
        }
        let (p, _, _) = re.swap_candidates(k, &mut rng);
        let mut swapped = t.clone();
        swapped[k] = re.chains[k].candidate;
        swapped[k + 1] = re.chains[k + 1].candidate;
        let j = tuple_index(&swapped, n);
        m.p[idx * size + j] += p;
        m.p[idx * size + idx] += 1.0 - p;
    }
    m
}

/// Lift per-level kernels (matrices over `0..n`) to the product space of tuples: every level
/// moves independently.
pub fn product_matrix(levels: &[TransitionMatrix]) -> TransitionMatrix {
    let n = levels[0].len();
    let k = levels.len();
    let size = n.pow(k as u32);
    TransitionMatrix::from_rows(size, |idx| {
        let t = tuple_of(idx, n, k);
        let mut out = vec![(0usize, 1.0f64)];
        for (l, m) in levels.iter().enumerate() {
            let mut next = Vec::new();
            for &(partial, p) in &out {
                for y in 0..n {
                    let q = m.get(t[l], y);
                    if q > 0.0 {
                        next.push((partial + y * n.pow(l as u32), p * q));
                    }
                }
            }
            out = next;
        }
        out
    })
}

/// The exact matrix over `(x, level)` pairs (index `x * K + level`) of one level move of a serial
/// tempering chain with neighbour proposals, computed with
/// [`crate::tempering::SerialTempering::level_candidate`].
pub fn level_move_matrix<F, K>(
    st: &mut crate::tempering::SerialTempering<usize, F, K>,
    n: usize,
) -> TransitionMatrix
where
    F: Family<usize>,
    K: Kernel<usize>,
{
    let levels = st.levels();
    let size = n * levels;
    let mut m = TransitionMatrix::zeros(size);
    let mut rng = stream(0, 0);
    for x in 0..n {
        for k in 0..levels {
            let idx = x * levels + k;
            st.level = k;
            st.chain.state = x;
            st.chain.ln_density = st.family.ln_density(k, &mut st.chain.state);
            let mut stay = 1.0;
            for j in [k.wrapping_sub(1), k + 1] {
                if j >= levels {
                    continue; // off the ladder: rejected
                }
                let (a, _) = st.level_candidate(j, 0.0, &mut rng);
                let y = st.chain.candidate;
                m.p[idx * size + y * levels + j] += 0.5 * a;
                stay -= 0.5 * a;
            }
            m.p[idx * size + idx] += stay;
        }
    }
    m
}
