//! Frequency-response estimation: experiments run on a pool of worker threads, each
//! forking its experiments from its own copy of the operating point (in-process) or
//! re-flying to it from t = 0 (a link that cannot be copied: QEMU), and the 3×3 response
//! `L = −U E⁻¹` assembled from the three columns of each frequency. Nothing but the
//! per-frequency DFTs is kept: memory does not grow with the experiments' length.

use super::MarginError;
use super::analysis::{C64, Cmat, loop_from_columns};
use super::excite::{self, Column, Effectiveness, Experiment, LoopPoint, Method};
use super::grid::Freq;
use sim_core::link::{self, FlightLink, LinkKind, LinkOptions};
use sim_core::scenario::{Resolved, Scenario};
use sim_core::simulation::probe::Probe;
use std::sync::{Mutex, mpsc};

/// What every experiment needs to reach the operating point and break the loop there.
pub struct Setup<'a> {
    pub scenario: &'a Scenario,
    pub link: LinkKind,
    pub link_options: LinkOptions,
    /// Control step of the operating point, and the first step checked for saturation.
    pub k_op: u64,
    pub check_from: u64,
    pub settle_bound_deg: f64,
    pub point: LoopPoint,
    pub effectiveness: Option<Effectiveness>,
    /// The loop closed, or broken open at the input.
    pub method: Method,
    /// Fork experiments from one flight to the operating point (in-process), or re-fly
    /// every experiment and its twin from t = 0.
    pub fork: bool,
    /// Freeze the flight law's adaptation at the operating point ([`super::freeze`]),
    /// before the forks or in every re-flown run.
    pub freeze_adaptation: bool,
}

impl Setup<'_> {
    /// A new run flown to the operating point against `link`.
    pub fn fly<'l>(&self, link: &'l mut dyn FlightLink) -> Result<Probe<'l>, MarginError> {
        let resolved = Resolved::try_from(self.scenario).map_err(MarginError::flight)?;
        let mut sim = Probe::new(resolved, link).map_err(MarginError::flight)?;
        excite::fly_to(&mut sim, self.k_op, self.check_from, self.settle_bound_deg)?;
        // What is frozen at the operating point for the experiments and their twins alike.
        excite::freeze_field(&mut sim)?;
        if self.freeze_adaptation {
            super::freeze::freeze(&mut sim)?;
        }
        Ok(sim)
    }

    fn open(&self) -> Result<Box<dyn FlightLink>, MarginError> {
        link::open(&self.link, &self.link_options).map_err(MarginError::flight)
    }

    fn run_forked(&self, base: &Probe, x: &Experiment) -> Result<Column, MarginError> {
        let fork = || base.fork_link().ok_or_else(|| MarginError::Flight("the link cannot be forked".into()));
        let (mut le, mut lt) = (fork()?, fork()?);
        let (mut exc, mut twin) = (base.fork(le.as_mut()), base.fork(lt.as_mut()));
        excite::run(&mut exc, &mut twin, self.point, self.effectiveness.as_ref(), self.method, x)
    }

    fn run_reflown(&self, x: &Experiment) -> Result<Column, MarginError> {
        let (mut le, mut lt) = (self.open()?, self.open()?);
        let mut exc = self.fly(le.as_mut())?;
        let mut twin = self.fly(lt.as_mut())?;
        excite::run(&mut exc, &mut twin, self.point, self.effectiveness.as_ref(), self.method, x)
    }
}

type Job = (usize, Experiment);
type Done = (usize, Result<Column, MarginError>);

/// Worker threads that run experiments in batches.
pub struct Pool {
    jobs: mpsc::Sender<Job>,
    done: mpsc::Receiver<Done>,
    /// Experiments and control steps run so far (both runs of each counted once).
    pub experiments: u64,
}

impl Pool {
    /// Runs `threads` workers for the duration of `body`, which submits batches.
    pub fn with<T>(setup: &Setup, threads: usize, body: impl FnOnce(&mut Pool) -> T) -> T {
        let (jobs, job_rx) = mpsc::channel::<Job>();
        let (done_tx, done) = mpsc::channel::<Done>();
        let job_rx = Mutex::new(job_rx);
        std::thread::scope(|scope| {
            for _ in 0..threads.max(1) {
                let (job_rx, done_tx) = (&job_rx, done_tx.clone());
                scope.spawn(move || worker(setup, job_rx, done_tx));
            }
            drop(done_tx);
            let mut pool = Pool { jobs, done, experiments: 0 };
            let out = body(&mut pool);
            drop(pool);
            out
        })
    }

    /// Runs every experiment, results in order; the first error (in order) if any failed.
    pub fn run(&mut self, xs: &[Experiment]) -> Result<Vec<Column>, MarginError> {
        for (i, x) in xs.iter().enumerate() {
            self.jobs.send((i, *x)).map_err(|_| MarginError::Flight("the experiment workers stopped".into()))?;
        }
        let mut out: Vec<Option<Result<Column, MarginError>>> = vec![None; xs.len()];
        for _ in 0..xs.len() {
            let (i, r) = self.done.recv().map_err(|_| MarginError::Flight("the experiment workers stopped".into()))?;
            out[i] = Some(r);
        }
        self.experiments += xs.len() as u64;
        out.into_iter()
            .map(|r| r.unwrap_or_else(|| Err(MarginError::Flight("an experiment was lost".into()))))
            .collect()
    }
}

fn next_job(rx: &Mutex<mpsc::Receiver<Job>>) -> Option<Job> {
    rx.lock().ok()?.recv().ok()
}

/// One worker: flies its own operating point once (when forking), then runs jobs until the
/// pool closes.
fn worker(setup: &Setup, rx: &Mutex<mpsc::Receiver<Job>>, tx: mpsc::Sender<Done>) {
    if !setup.fork {
        while let Some((i, x)) = next_job(rx) {
            let _ = tx.send((i, setup.run_reflown(&x)));
        }
        return;
    }
    let mut link = match setup.open() {
        Ok(l) => l,
        Err(e) => return fail_all(rx, &tx, &e),
    };
    let base = match setup.fly(link.as_mut()) {
        Ok(b) => b,
        Err(e) => return fail_all(rx, &tx, &e),
    };
    while let Some((i, x)) = next_job(rx) {
        let _ = tx.send((i, setup.run_forked(&base, &x)));
    }
}

fn fail_all(rx: &Mutex<mpsc::Receiver<Job>>, tx: &mpsc::Sender<Done>, e: &MarginError) {
    while let Some((i, _)) = next_job(rx) {
        let _ = tx.send((i, Err(e.clone())));
    }
}

/// The measured response: ascending frequencies, `L` at each, and what the experiments of
/// each frequency reported.
#[derive(Clone, Debug, Default)]
pub struct Response {
    pub freqs: Vec<Freq>,
    pub l: Vec<Cmat>,
    pub columns: Vec<[Column; 3]>,
}

impl Response {
    /// Adds the three columns of `f` (column j: axis j excited), keeping frequencies sorted.
    pub fn insert(&mut self, f: Freq, cols: [Column; 3], dt: f64) -> Result<(), MarginError> {
        let u: Cmat = std::array::from_fn(|i| std::array::from_fn(|j| cols[j].u[i]));
        let e: Cmat = std::array::from_fn(|i| std::array::from_fn(|j| cols[j].e[i]));
        let l = loop_from_columns(&u, &e).ok_or_else(|| MarginError::Unstable {
            reason: format!("the total input is singular at {:.6} rad/s", f.rad_s(dt)),
        })?;
        let w = f.rad_s(dt);
        let at = self.freqs.partition_point(|g| g.rad_s(dt) < w);
        self.freqs.insert(at, f);
        self.l.insert(at, l);
        self.columns.insert(at, cols);
        Ok(())
    }

    pub fn contains(&self, f: &Freq) -> bool {
        self.freqs.contains(f)
    }

    pub fn rad_s(&self, dt: f64) -> Vec<f64> {
        self.freqs.iter().map(|f| f.rad_s(dt)).collect()
    }
}

/// `L_jj ≈ −u_j / e_j` of one column alone (the pilot's crossover estimate).
pub fn diagonal_estimate(c: &Column, j: usize) -> C64 {
    -c.u[j] / c.e[j]
}
