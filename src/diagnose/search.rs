//! Fitting an effect's few parameters by output error on the training runs: a grid over the
//! bounds (the cost of a delay or a deadband is not convex), then Nelder-Mead from the best
//! grid point, in coordinates scaled to the bounds and clamped to them.
//!
//! The cost takes a bound: the value a point must beat to change the search's next move
//! (the best grid point so far; for a reflected point the second-worst vertex, and so on).
//! A point certain to reach it may be answered with infinity instead of its cost
//! ([`super::Data::train_cost_below`]), which leaves every decision, and so the result,
//! as it would be with exact costs.

use super::discover::Discovered;
use super::{Data, Hypothesis, Selection, augmentation};
use crate::core::model::Plant;
use std::sync::Arc;

/// Grid points per parameter: 17 for one, 7 x 7 for two.
fn grid(k: usize) -> usize {
    match k {
        1 => 17,
        2 => 7,
        _ => 4,
    }
}

/// A point and its cost.
type Vertex = (Vec<f64>, f64);

/// A cost at a point, exact below the bound (second argument), possibly infinite above it.
type Cost<'a> = &'a dyn Fn(&[f64], f64) -> f64;

/// The starting simplex: `x0` and one step along each axis (back where a step forward would
/// leave the unit box).
fn initial_simplex(f: Cost, x0: &[f64], step: f64) -> Vec<Vertex> {
    let mut simplex: Vec<Vertex> = Vec::with_capacity(x0.len() + 1);
    simplex.push((x0.to_vec(), f(x0, f64::INFINITY)));
    for i in 0..x0.len() {
        let mut x = x0.to_vec();
        x[i] = if x[i] + step <= 1.0 {
            x[i] + step
        } else {
            x[i] - step
        };
        let x: Vec<f64> = x.into_iter().map(|v| v.clamp(0.0, 1.0)).collect();
        let fx = f(&x, f64::INFINITY);
        simplex.push((x, fx));
    }
    simplex
}

/// Every vertex but the best moves halfway towards it.
fn shrink(f: Cost, simplex: &mut [Vertex]) {
    let best = simplex[0].0.clone();
    for s in simplex.iter_mut().skip(1) {
        let x: Vec<f64> = best
            .iter()
            .zip(&s.0)
            .map(|(b, v)| b + 0.5 * (v - b))
            .collect();
        let fx = f(&x, f64::INFINITY);
        *s = (x, fx);
    }
}

/// Minimises `f` over the unit box [0, 1]^k from `x0` (Nelder-Mead, clamped), `iters` steps.
pub fn nelder_mead(f: Cost, x0: &[f64], step: f64, iters: usize) -> (Vec<f64>, f64) {
    let k = x0.len();
    let clamp = |x: Vec<f64>| -> Vec<f64> { x.into_iter().map(|v| v.clamp(0.0, 1.0)).collect() };
    let mut simplex = initial_simplex(f, x0, step);
    for _ in 0..iters {
        // Ctrl-C: the stage's result is thrown away (see the executor), so stopping is safe.
        if crate::core::interrupt::requested() {
            break;
        }
        simplex.sort_by(|a, b| a.1.total_cmp(&b.1));
        let spread = simplex
            .iter()
            .flat_map(|(x, _)| x.iter().zip(&simplex[0].0).map(|(a, b)| (a - b).abs()))
            .fold(0.0f64, f64::max);
        if spread < 1e-4 {
            break;
        }
        let centroid: Vec<f64> = (0..k)
            .map(|i| simplex[..k].iter().map(|(x, _)| x[i]).sum::<f64>() / k as f64)
            .collect();
        let worst = simplex[k].clone();
        let along = |t: f64| {
            clamp(
                centroid
                    .iter()
                    .zip(&worst.0)
                    .map(|(c, w)| c + t * (c - w))
                    .collect(),
            )
        };
        let xr = along(1.0);
        // Past the second-worst vertex the reflection's cost is not used again.
        let fr = f(&xr, simplex[k - 1].1);
        if fr < simplex[0].1 {
            let xe = along(2.0);
            let fe = f(&xe, fr);
            simplex[k] = if fe < fr { (xe, fe) } else { (xr, fr) };
        } else if fr < simplex[k - 1].1 {
            simplex[k] = (xr, fr);
        } else {
            let xc = along(-0.5);
            let fc = f(&xc, worst.1);
            if fc < worst.1 {
                simplex[k] = (xc, fc);
            } else {
                shrink(f, &mut simplex);
            }
        }
    }
    simplex.sort_by(|a, b| a.1.total_cmp(&b.1));
    simplex.swap_remove(0)
}

/// Where grid position `t` (0 to 1, evenly spaced) of parameter `i` of `h` lies in the unit
/// box, on data of a vehicle of `size` ([`Data::size`]). A force-like parameter (in newtons)
/// whose range starts at 0 (a threshold, a drag coefficient) is a size, its range set for the
/// reference vehicle: on a smaller one its grid spans that share of the range (a deadband's
/// force on a vehicle a third the size is tried at 0, 3.3, 6.5 and 9.8 N, not 0, 10, 20 and
/// 30), and Nelder-Mead is free to leave it.
fn grid_point(h: &Hypothesis, i: usize, t: f64, size: f64) -> f64 {
    t * h.params[i].share(size)
}

/// The parameters at unit-box point `u`, on a vehicle of `size` ([`super::Param::bounds`]).
fn to_params(h: &Hypothesis, u: &[f64], size: f64) -> Vec<f64> {
    h.params
        .iter()
        .zip(u)
        .map(|(q, x)| {
            let (lo, hi) = q.bounds(size);
            lo + x * (hi - lo)
        })
        .collect()
}

fn to_unit(h: &Hypothesis, p: &[f64], size: f64) -> Vec<f64> {
    h.params
        .iter()
        .zip(p)
        .map(|(q, x)| {
            let (lo, hi) = q.bounds(size);
            ((x - lo) / (hi - lo)).clamp(0.0, 1.0)
        })
        .collect()
}

/// Fits `h` on the training runs with the effects already `selected` held at their values.
/// Returns the parameters and the training cost.
pub fn fit_one(
    plant: &Plant,
    data: &Data,
    selected: &Selection,
    h: &'static Hypothesis,
) -> (Vec<f64>, f64) {
    fit_beside(plant, data, (selected, &[]), h)
}

/// [`fit_one`] with discovered terms `beside` in the model as they are.
pub fn fit_beside(
    plant: &Plant,
    data: &Data,
    (selected, beside): (&Selection, &[Arc<Discovered>]),
    h: &'static Hypothesis,
) -> (Vec<f64>, f64) {
    let k = h.params.len();
    let cost = |u: &[f64], bound: f64| {
        let mut sel = selected.clone();
        sel.push((h, to_params(h, u, data.size)));
        let mut aug = augmentation(&sel);
        aug.discovered = beside.to_vec();
        data.train_cost_below(plant, &aug, bound)
    };
    let g = grid(k);
    let mut best = (vec![0.0; k], f64::INFINITY);
    let total = g.pow(k as u32);
    for idx in 0..total {
        if crate::core::interrupt::requested() {
            break;
        }
        let u: Vec<f64> = (0..k)
            .map(|i| {
                let t = ((idx / g.pow(i as u32)) % g) as f64 / (g - 1) as f64;
                grid_point(h, i, t, data.size)
            })
            .collect();
        let c = cost(&u, best.1);
        if c < best.1 {
            best = (u, c);
        }
    }
    let (u, c) = nelder_mead(&cost, &best.0, 0.5 / (g - 1) as f64, 40 * k);
    (to_params(h, &u, data.size), c)
}

/// Refits every kept effect's parameters together, from their current values, with the
/// discovered terms `beside` in the model as they are.
pub fn refine_all(
    plant: &Plant,
    data: &Data,
    selected: &Selection,
    beside: &[Arc<Discovered>],
) -> Selection {
    let sizes: Vec<usize> = selected.iter().map(|(h, _)| h.params.len()).collect();
    let split = |u: &[f64]| -> Selection {
        let mut at = 0;
        selected
            .iter()
            .zip(&sizes)
            .map(|((h, _), n)| {
                let p = to_params(h, &u[at..at + n], data.size);
                at += n;
                (*h, p)
            })
            .collect()
    };
    let u0: Vec<f64> = selected
        .iter()
        .flat_map(|(h, p)| to_unit(h, p, data.size))
        .collect();
    let cost = |u: &[f64], bound: f64| {
        let mut aug = augmentation(&split(u));
        aug.discovered = beside.to_vec();
        data.train_cost_below(plant, &aug, bound)
    };
    let (u, _) = nelder_mead(&cost, &u0, 0.05, 40 * u0.len());
    split(&u)
}

#[cfg(test)]
mod tests {
    use super::nelder_mead;

    #[test]
    fn a_cost_that_gives_up_above_its_bound_leaves_nelder_mead_where_the_exact_cost_does() {
        // A curved valley in the unit box, minimum at (0.7, 0.49).
        let f = |x: &[f64]| (x[0] - 0.7).powi(2) + 10.0 * (x[1] - x[0] * x[0]).powi(2);
        let exact = |x: &[f64], _: f64| f(x);
        let pruned = |x: &[f64], bound: f64| if f(x) >= bound { f64::INFINITY } else { f(x) };
        for x0 in [[0.1, 0.9], [0.5, 0.0], [1.0, 1.0]] {
            let (xa, ca) = nelder_mead(&exact, &x0, 0.2, 200);
            let (xb, cb) = nelder_mead(&pruned, &x0, 0.2, 200);
            assert_eq!(
                (xa.clone(), ca.to_bits()),
                (xb, cb.to_bits()),
                "from {x0:?}"
            );
            assert!((xa[0] - 0.7).abs() < 1e-2 && ca < 1e-4, "{xa:?} {ca}");
        }
    }
}
