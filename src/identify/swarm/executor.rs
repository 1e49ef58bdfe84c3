//! The executor: a solver's seeded restarts under the iteration and time limits, with progress;
//! the local refinement of an output-error answer; the restarts' answers turned into estimates.

use super::{Problem, Solver};
use crate::core::rng::Rng;
use crate::identify::output_error::OutputError;
use crate::identify::refine::{Refined, output_error_lm};
use crate::identify::{Estimate, EstimateError, Fit, Options, Regression, ols};
use std::time::Instant;

/// One restart's answer: the best coefficients it found and their cost.
type Answer = (Vec<f64>, f64);

/// Runs a solver: `restarts` independent seeded runs (the spread of their answers is the
/// reported interval), each `iterations` long.
pub fn execute(
    name: &str,
    make: &dyn Fn() -> Box<dyn Solver>,
    reg: &Regression,
    rigid_mass: &[f64; 6],
    opts: &Options,
) -> Result<Fit, EstimateError> {
    ols::check_excitation(reg)?;
    let mut problem = Problem::new(reg, rigid_mass, opts.norm);
    if let Some((vehicle, responses)) = opts.output_error {
        problem = problem.with_output_error(OutputError::new(vehicle, responses));
    }
    let search = Search {
        name,
        make,
        problem: &problem,
        opts,
        started: Instant::now(),
    };
    let (answers, stopped_early) = search.run()?;
    let outcome = Outcome::of(answers, reg, opts);
    let mut fit = outcome.fit(reg, &problem, stopped_early);
    say_beyond_prior(&mut fit, reg, rigid_mass, &opts.added_mass_prior);
    Ok(fit)
}

/// Says where a diagonal added mass came out beyond the plausibility prior the default fit
/// holds it in (`prior` times the rigid-body term): said, not flagged, since a vehicle may
/// have it (the seed-001 ROV's heave is 2.4 times), but a search bounded only at 5 times let a
/// real vehicle's added inertia take 4.5 times and predict held-out yaw worse.
pub(super) fn say_beyond_prior(
    fit: &mut Fit,
    reg: &Regression,
    rigid_mass: &[f64; 6],
    prior: &[f64; 6],
) {
    use crate::core::model::params::Group;
    for (t, p) in reg.layout.terms.iter().zip(&mut fit.parameters) {
        let (i, name) = (t.dof().index(), &p.name);
        let beyond = t.group() == Group::AddedMass
            && t.is_diagonal()
            && rigid_mass[i] > 0.0
            && p.value < -prior[i] * rigid_mass[i];
        if beyond && p.note.is_none() {
            p.note = Some(format!(
                "{name} is {:.1} times the rigid-body term {:.3}, beyond the plausibility prior the default fit holds it in ({} times): an open-frame vehicle's added mass is seldom so large, and a search free to take it can let it stand in for what the model lacks (a command lag, a command that delivers less than it asks); the default fit (no `method`) keeps it within the prior unless the runs demand more",
                -p.value / rigid_mass[i],
                rigid_mass[i],
                prior[i]
            ));
        }
    }
}

/// A solver's restarts and the limits they run under.
struct Search<'a, 'p> {
    name: &'a str,
    make: &'a dyn Fn() -> Box<dyn Solver>,
    problem: &'a Problem<'p>,
    opts: &'a Options<'p>,
    started: Instant,
}

impl Search<'_, '_> {
    fn restarts(&self) -> usize {
        self.opts.restarts.max(1)
    }

    /// Every restart in turn until one stops early: their answers, best first, and why the
    /// search stopped early, if it did.
    fn run(&self) -> Result<(Vec<Answer>, Option<String>), EstimateError> {
        let mut answers = Vec::new();
        let mut stopped_early = None;
        for r in 0..self.restarts() {
            let (answer, stopped) = self.restart(r)?;
            answers.push(answer);
            if stopped.is_some() {
                stopped_early = stopped;
                break;
            }
        }
        answers.sort_by(|a, b| a.1.total_cmp(&b.1));
        Ok((answers, stopped_early))
    }

    /// Restart `r` from its own seed: its best answer, and why it stopped early if it did.
    fn restart(&self, r: usize) -> Result<(Answer, Option<String>), EstimateError> {
        let (name, opts) = (self.name, self.opts);
        let mut rng = Rng::derive(opts.seed, &format!("{name}/restart/{r}"));
        let mut solver = (self.make)();
        let mut swarm = solver.init(self.problem, &mut rng, opts.population);
        let mut stopped = None;
        for it in 0..opts.iterations {
            if crate::core::interrupt::requested() {
                return Err(EstimateError::Interrupted);
            }
            stopped = self.past_time_limit(r, it);
            if stopped.is_some() {
                break;
            }
            solver.step(
                self.problem,
                &mut swarm,
                &mut rng,
                it as f64 / opts.iterations.max(1) as f64,
            );
            self.report(r, it);
        }
        let answer = (swarm.best[swarm.g].clone(), swarm.best_cost[swarm.g]);
        Ok((answer, stopped))
    }

    /// Why the search stops before iteration `it` of restart `r`, when its time limit is past.
    fn past_time_limit(&self, r: usize, it: usize) -> Option<String> {
        let opts = self.opts;
        let limit = opts
            .max_seconds
            .filter(|l| self.started.elapsed().as_secs_f64() > *l)?;
        Some(format!(
            "time limit of {limit} s reached in restart {} of {} after {it} of {} iterations",
            r + 1,
            self.restarts(),
            opts.iterations
        ))
    }

    /// Reports the share of all iterations done once iteration `it` of restart `r` is.
    fn report(&self, r: usize, it: usize) {
        let opts = self.opts;
        if let Some(p) = opts.progress {
            p((r * opts.iterations + it + 1) as f64 / (self.restarts() * opts.iterations) as f64);
        }
    }
}

/// What the restarts found, best first, and the values reported: the best answer, or its
/// local refinement under the output error.
struct Outcome {
    answers: Vec<Answer>,
    best: Vec<f64>,
    refined: Option<Refined>,
}

impl Outcome {
    /// The answers of the restarts, sorted best first, with the output error's refinement.
    fn of(answers: Vec<Answer>, reg: &Regression, opts: &Options) -> Outcome {
        let mut best = answers[0].0.clone();
        // Output error: a local least-squares refinement from the best answer gives the final
        // values and, from its Jacobian, their standard errors.
        let refined = opts.output_error.map(|(vehicle, responses)| {
            let oe = OutputError::new(vehicle, responses);
            let r = output_error_lm(&oe, &reg.layout, &best, 30);
            best = r.theta.clone();
            r
        });
        Outcome {
            answers,
            best,
            refined,
        }
    }

    /// The fit: every parameter, the residuals and the conditioning at the reported values.
    fn fit(self, reg: &Regression, problem: &Problem, stopped_early: Option<String>) -> Fit {
        let residual = ols::residual_sigma(reg, &self.best);
        // The regressor's conditioning does not depend on the method: take it from the LS summary.
        let condition_number = ols::summarise(reg, &self.best, &residual).condition_number;
        let regression_se = problem.regression_stderr(&self.best);
        let parameters = (0..self.best.len())
            .map(|j| self.estimate(j, reg, problem, regression_se[j]))
            .collect();
        Fit {
            parameters,
            residual_sigma: residual
                .iter()
                .map(|(d, s)| (d.name().to_string(), *s))
                .collect(),
            samples: reg.rows(),
            condition_number,
            evaluations: Some(problem.evaluations()),
            objective_value: Some(
                self.refined
                    .as_ref()
                    .map_or(self.answers[0].1, |r| r.cost_after),
            ),
            stopped_early,
            ..Fit::default()
        }
    }

    /// Parameter `j`: its value, its uncertainty (the refinement's standard error, else the
    /// spread of the restarts beside `regression_se`, the equation error's own standard error
    /// at the answer) and whether the data determine it.
    fn estimate(
        &self,
        j: usize,
        reg: &Regression,
        problem: &Problem,
        regression_se: f64,
    ) -> Estimate {
        let best = &self.best;
        let refined = &self.refined;
        let vals: Vec<f64> = self.answers.iter().map(|a| a.0[j]).collect();
        let (lo, hi, sd) = spread(&vals);
        let at_bound = (best[j] - problem.lo[j]).abs() < 1e-6 * problem.lo[j].abs().max(1.0)
            || best[j].abs() < 1e-9;
        // One search run has no spread to judge a value by.
        let single = vals.len() < 2;
        // Restarts that agree say the search converged, not that the data fix the value to
        // their spread (a real run's restarts agreed to 1e-9 on a coefficient whose
        // regression error was 4 %): the regression's own error is added to the spread.
        let stderr = match refined {
            Some(r) => r.stderr[j],
            None if single => f64::NAN,
            None => sd.hypot(regression_se),
        };
        let spread_ok = refined.is_some() || (!single && (hi - lo) < 0.5 * best[j].abs());
        Estimate {
            name: reg.layout.name(j),
            value: best[j],
            unit: reg.layout.unit(j).to_string(),
            stderr,
            interval: Some([lo, hi]),
            // Wide disagreement between restarts, a standard error over half the value,
            // or a value pinned to a bound means the data (or the search) did not
            // determine it.
            identifiable: !at_bound
                && spread_ok
                && stderr.is_finite()
                && stderr < 0.5 * best[j].abs(),
            note: note(at_bound, single && refined.is_none()),
        }
    }
}

/// The restarts' values of one parameter: lowest, highest and their standard deviation.
fn spread(vals: &[f64]) -> (f64, f64, f64) {
    let (lo, hi) = vals
        .iter()
        .fold((f64::INFINITY, f64::NEG_INFINITY), |(l, h), v| {
            (l.min(*v), h.max(*v))
        });
    let mean = vals.iter().sum::<f64>() / vals.len() as f64;
    let sd = (vals.iter().map(|v| (v - mean).powi(2)).sum::<f64>()
        / (vals.len().max(2) - 1) as f64)
        .sqrt();
    (lo, hi, sd)
}

/// Why a parameter's value is not to be trusted, beyond its uncertainty: pinned to its search
/// bound, or from one search run with nothing to judge it by (`unjudged`).
fn note(at_bound: bool, unjudged: bool) -> Option<String> {
    if at_bound {
        Some("pinned to its search bound: the data (or the search) did not determine it".into())
    } else if unjudged {
        Some("one search run only (time limit): no spread across restarts to judge it by".into())
    } else {
        None
    }
}
