//! Plant models (f64). The spacecraft is a rigid body carrying momentum-exchange
//! actuators (CMGs, reaction wheels), magnetorquers and thrusters, possibly mounted on an
//! air-bearing rig; one RK4 integrates body, gimbal and wheel states at a fixed step that
//! is an integer fraction of the control period; the quaternion is renormalised after
//! every step.
//!
//! Body (papers 000 eqs 1-4 and 001 eqs 2-5), with `J` the inertia without the wheels'
//! axial rotor inertia, `h_a` the wheels' absolute axial momenta, `h` the CMG momentum:
//! `H = J ω + h + C h_a`,
//! `J ω̇ = T_ext - ω × H - ḣ - C ḣ_a + T_imbalance`, `ḣ = Σ δ̇_i (g_i × h_i)`,
//! `q̇ = ½ q ⊗ [ω; 0]`.
//! External torques: environment (gravity gradient, drag, SRP, constant/harmonic), the
//! rig's pendulum and stops, `m × B` of the spacecraft dipole (torquers + residual), and
//! the thrusters' torque averaged over the step (exact impulse, see `thrusters`).
//! With an environment, [`Spacecraft::rk4_env`] evaluates it at every RK4 stage time
//! (`t`, `t + h/2`, `t + h`; cached, see `environment::model`), so the orbit-dependent
//! torques are integrated at fourth order like the rest.

pub mod cmg;
pub mod delay;
pub mod magnetorquers;
pub mod rig;
pub mod thrusters;
pub mod wheel;

use crate::attitude::{Quat, Vec3, dcm_body_to_ref, rotate_ref_to_body};
use crate::environment::model::{EnvSnapshot, Environment, Parts, SnapshotCache};
use crate::environment::torques::TorqueBreakdown;
use cmg::CmgCluster;
use nalgebra::Matrix3;
use rig::Rig;
use wheel::{WheelDeriv, WheelOutput, WheelParams, WheelState};

/// Largest number of gimbals the fixed-size state holds.
pub const MAX_GIMBALS: usize = 8;
/// Largest number of wheels the fixed-size state holds.
pub const MAX_WHEELS: usize = acs_flight::types::MAX_WHEELS;

#[derive(Clone, Copy, Debug, PartialEq)]
pub struct State {
    /// `q_ib`, body → inertial (or → lab on a rig).
    pub q: Quat,
    /// Body rate, body axes, rad/s.
    pub w: Vec3,
    pub gimbal_rad: [f64; MAX_GIMBALS],
    /// Actual gimbal rates (a state only with a gimbal servo model; else the command).
    pub gimbal_rate_rad_s: [f64; MAX_GIMBALS],
    pub wheels: [WheelState; MAX_WHEELS],
    /// Each CMG rotor's momentum as a fraction of its `h0_nms` (1 unless a spin-down fault
    /// acted).
    pub cmg_rotor_scale: [f64; MAX_GIMBALS],
}

/// Every CMG rotor at its nominal momentum ([`State::cmg_rotor_scale`]).
pub const NOMINAL_ROTORS: [f64; MAX_GIMBALS] = [1.0; MAX_GIMBALS];

/// Actuator inputs held constant over one dynamics step (zero-order hold).
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct Input {
    pub gimbal_rate_cmd_rad_s: [f64; MAX_GIMBALS],
    /// Motor torque command per wheel (on the rotor; the body gets the reaction).
    pub wheel_torque_cmd_nm: [f64; MAX_WHEELS],
    /// Total spacecraft dipole (torquer rods as realised + residual), body axes, A m².
    pub dipole_am2: Vec3,
    /// Thruster torque averaged over the step, body axes.
    pub thruster_torque_nm: Vec3,
}

#[derive(Clone, Copy, Debug)]
struct Deriv {
    dq: Quat,
    dw: Vec3,
    dgimbal: [f64; MAX_GIMBALS],
    dgimbal_rate: [f64; MAX_GIMBALS],
    dwheel: [wheel::WheelDeriv; MAX_WHEELS],
    drotor_scale: [f64; MAX_GIMBALS],
}

/// Every torque acting on the body at one instant, for telemetry and tests.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct TorqueReport {
    pub env: TorqueBreakdown,
    pub rig_nm: Vec3,
    pub magnetic_nm: Vec3,
    pub thrusters_nm: Vec3,
    /// CMG: `-ḣ - ω × h`; wheels: `-C ḣ_a - ω × C h_a` (+ imbalance).
    pub actuators_nm: Vec3,
}

#[derive(Clone, Debug)]
pub struct Spacecraft {
    /// Inertia without the wheels' axial rotor inertia (`J` of paper 001 eq 3).
    pub inertia: Matrix3<f64>,
    inertia_inv: Matrix3<f64>,
    pub cmg: Option<CmgCluster>,
    pub wheels: Vec<WheelParams>,
    pub rig: Option<Rig>,
    pub env: Option<Environment>,
    /// Constant external torque, body axes, N m.
    pub external_torque_nm: Vec3,
    /// Snapshots of `env` at the latest stage times (valid for this `env` only).
    env_cache: SnapshotCache,
    /// Wheels seized by an injected fault now ([`wheel::seized`]; set by the run loop).
    pub seized: [bool; MAX_WHEELS],
    /// Each wheel's friction factor by an injected fault now (1: none; set by the run loop).
    pub friction_factor: [f64; MAX_WHEELS],
    /// CMG gimbals seized by an injected fault now: rate 0 whatever the command (set by
    /// the run loop).
    pub gimbal_stuck: [bool; MAX_GIMBALS],
    /// Each CMG rotor's spin-down rate by the injected faults now, `Σ 1/τ`, 1/s
    /// (`d scale/dt = -rate · scale`; 0: none; set by the run loop).
    pub rotor_decay_per_s: [f64; MAX_GIMBALS],
}

impl Spacecraft {
    /// `None` if the inertia is not invertible.
    pub fn new(inertia: Matrix3<f64>, cmg: Option<CmgCluster>) -> Option<Self> {
        Some(Self {
            inertia,
            inertia_inv: inertia.try_inverse()?,
            cmg,
            wheels: Vec::new(),
            rig: None,
            env: None,
            external_torque_nm: Vec3::zeros(),
            env_cache: SnapshotCache::default(),
            seized: [false; MAX_WHEELS],
            friction_factor: [1.0; MAX_WHEELS],
            gimbal_stuck: [false; MAX_GIMBALS],
            rotor_decay_per_s: [0.0; MAX_GIMBALS],
        })
    }

    /// Change the body inertia (`J`, without the wheels' axial inertia) during a run.
    pub fn set_inertia(&mut self, inertia: Matrix3<f64>) -> bool {
        match inertia.try_inverse() {
            Some(inv) => {
                self.inertia = inertia;
                self.inertia_inv = inv;
                self.env.iter_mut().for_each(|e| e.disturbances.inertia = inertia);
                true
            }
            None => false,
        }
    }

    /// Gimbal rates the hardware actually applies: with an ideal servo the command after
    /// the rate limit and angle stops, with a servo model the lagging state; a seized
    /// gimbal's is 0.
    pub fn applied_gimbal_rates(&self, s: &State, u: &Input) -> [f64; MAX_GIMBALS] {
        let mut r = [0.0; MAX_GIMBALS];
        if let Some(c) = &self.cmg {
            for i in 0..c.units.len() {
                r[i] = match c.servo {
                    _ if self.gimbal_stuck[i] => 0.0,
                    Some(_) => s.gimbal_rate_rad_s[i],
                    None => c.applied_rate(u.gimbal_rate_cmd_rad_s[i], s.gimbal_rad[i]),
                };
            }
        }
        r
    }

    fn gimbal_accel(&self, s: &State, u: &Input) -> [f64; MAX_GIMBALS] {
        let mut a = [0.0; MAX_GIMBALS];
        if let Some(c) = &self.cmg
            && let Some(servo) = &c.servo
        {
            for i in (0..c.units.len()).filter(|i| !self.gimbal_stuck[*i]) {
                let cmd = c.applied_rate(u.gimbal_rate_cmd_rad_s[i], s.gimbal_rad[i]);
                a[i] = servo.accel(cmd, s.gimbal_rate_rad_s[i]);
            }
        }
        a
    }

    /// Each rotor's `d scale/dt` at `s` (spin-down faults).
    fn rotor_scale_rate(&self, s: &State) -> [f64; MAX_GIMBALS] {
        let mut d = [0.0; MAX_GIMBALS];
        for ((d, k), x) in d.iter_mut().zip(&self.rotor_decay_per_s).zip(&s.cmg_rotor_scale) {
            if *k != 0.0 {
                *d = -k * x;
            }
        }
        d
    }

    /// The CMG cluster's momentum and its rate `ḣ` (gimbal motion and rotor spin-down) at
    /// `s` with the applied gimbal `rates`, body axes (zeros without CMGs).
    pub fn cmg_momentum_and_rate(&self, s: &State, rates: &[f64; MAX_GIMBALS]) -> (Vec3, Vec3) {
        match &self.cmg {
            Some(c) => c.momentum_and_rate_scaled(&s.gimbal_rad, rates, &s.cmg_rotor_scale, &self.rotor_scale_rate(s)),
            None => (Vec3::zeros(), Vec3::zeros()),
        }
    }

    /// Actuator momentum in body axes (CMG cluster + wheels' absolute axial momentum).
    pub fn actuator_momentum(&self, s: &State) -> Vec3 {
        let mut h = self.cmg.as_ref().map_or(Vec3::zeros(), |c| c.momentum_scaled(&s.gimbal_rad, &s.cmg_rotor_scale));
        for (p, ws) in self.wheels.iter().zip(s.wheels.iter()) {
            h += Vec3::from(p.spin_axis) * ws.h_abs_nms;
        }
        h
    }

    /// Wheel outputs (speed, current, power, …) at a state and input.
    pub fn wheel_outputs(&self, s: &State, u: &Input) -> [WheelOutput; MAX_WHEELS] {
        self.wheel_evaluations(s, u).map(|(_, o)| o)
    }

    /// Every wheel's derivatives and outputs at `s` under `u` (`wheel::evaluate`; default
    /// past the last wheel): what [`Spacecraft::wheel_outputs`] and the actuator torque are
    /// made of, computed once for both at a recorded step ([`Spacecraft::torques_with`]).
    pub fn wheel_evaluations(&self, s: &State, u: &Input) -> [(WheelDeriv, WheelOutput); MAX_WHEELS] {
        let mut e = [(WheelDeriv::default(), WheelOutput::default()); MAX_WHEELS];
        let w: [f64; 3] = s.w.into();
        for (i, p) in self.wheels.iter().enumerate() {
            e[i] = self.wheel_at(i, p, s, u, &w);
        }
        e
    }

    /// Wheel `i` evaluated at `s` under `u`, seized when a fault says so.
    fn wheel_at(&self, i: usize, p: &WheelParams, s: &State, u: &Input, w: &[f64; 3]) -> (WheelDeriv, WheelOutput) {
        let k = self.friction_factor[i];
        let e = if k == 1.0 {
            wheel::evaluate(p, &s.wheels[i], u.wheel_torque_cmd_nm[i], w, &[0.0; 3])
        } else {
            // Friction fault: the viscous and Coulomb (Dahl) levels scaled.
            let q = WheelParams { viscous_nms: p.viscous_nms * k, coulomb_nm: p.coulomb_nm * k, ..p.clone() };
            wheel::evaluate(&q, &s.wheels[i], u.wheel_torque_cmd_nm[i], w, &[0.0; 3])
        };
        if self.seized[i] { wheel::seized(e) } else { e }
    }

    fn external(&self, t: f64, s: &State, u: &Input, env: Option<&EnvSnapshot>) -> TorqueReport {
        let mut r = TorqueReport { thrusters_nm: u.thruster_torque_nm, ..Default::default() };
        if let (Some(e), Some(snap)) = (&self.env, env) {
            r.env = e.torques(t, &s.q, snap);
            if let Some(b) = snap.b_ref_t {
                r.magnetic_nm = u.dipole_am2.cross(&rotate_ref_to_body(&s.q, &b));
            }
        }
        if let Some(rig) = &self.rig {
            r.rig_nm = rig.torque(&s.q, &s.w, &self.inertia);
        }
        r
    }

    /// Every torque on the body at a state (telemetry).
    pub fn torques(&self, t: f64, s: &State, u: &Input, env: Option<&EnvSnapshot>) -> TorqueReport {
        self.torques_with(t, s, u, env, &self.wheel_evaluations(s, u))
    }

    /// [`Spacecraft::torques`] with the wheels already evaluated at `s` under `u`
    /// ([`Spacecraft::wheel_evaluations`]).
    pub fn torques_with(
        &self,
        t: f64,
        s: &State,
        u: &Input,
        env: Option<&EnvSnapshot>,
        wheels: &[(WheelDeriv, WheelOutput); MAX_WHEELS],
    ) -> TorqueReport {
        let mut r = self.external(t, s, u, env);
        r.actuators_nm = self.actuator_torque_with(s, u, wheels);
        r
    }

    /// Torque the momentum-exchange actuators exert on the body: `-ḣ - ω × h` (eq 4).
    pub fn actuator_torque(&self, s: &State, u: &Input) -> Vec3 {
        self.actuator_torque_with(s, u, &self.wheel_evaluations(s, u))
    }

    fn actuator_torque_with(&self, s: &State, u: &Input, wheels: &[(WheelDeriv, WheelOutput); MAX_WHEELS]) -> Vec3 {
        let rates = self.applied_gimbal_rates(s, u);
        let mut t = Vec3::zeros();
        if let Some(c) = &self.cmg {
            // Summed in the order of the recorded torque before rotor faults (bit for bit).
            let (scale, scale_rate) = (&s.cmg_rotor_scale, &self.rotor_scale_rate(s));
            t += -c.momentum_rate_scaled(&s.gimbal_rad, &rates, scale, scale_rate)
                - s.w.cross(&c.momentum_scaled(&s.gimbal_rad, scale));
        }
        for (i, (p, (d, o))) in self.wheels.iter().zip(wheels).enumerate() {
            let a = Vec3::from(p.spin_axis);
            t += -a * d.dh_abs_nm - s.w.cross(&(a * s.wheels[i].h_abs_nms)) + Vec3::from(o.imbalance_torque_nm);
        }
        t
    }

    fn deriv(&self, t: f64, s: &State, u: &Input, env: Option<&EnvSnapshot>) -> Deriv {
        let rates = self.applied_gimbal_rates(s, u);
        let (h, hdot) = self.cmg_momentum_and_rate(s, &rates);
        let mut h_total = h;
        let mut torque = self.external_torque_nm - hdot;
        let mut dwheel = [wheel::WheelDeriv::default(); MAX_WHEELS];
        let w: [f64; 3] = s.w.into();
        for (i, p) in self.wheels.iter().enumerate() {
            let (d, o) = self.wheel_at(i, p, s, u, &w);
            let a = Vec3::from(p.spin_axis);
            h_total += a * s.wheels[i].h_abs_nms;
            torque += -a * d.dh_abs_nm + Vec3::from(o.imbalance_torque_nm);
            dwheel[i] = d;
        }
        let ext = self.external(t, s, u, env);
        torque += ext.env.total + ext.rig_nm + ext.magnetic_nm + ext.thrusters_nm;
        let big_h = self.inertia * s.w + h_total;
        let dw = self.inertia_inv * (torque - s.w.cross(&big_h));
        let dq = s.q * Quat::from_imag(s.w) * 0.5;
        let (dgimbal_rate, drotor_scale) = (self.gimbal_accel(s, u), self.rotor_scale_rate(s));
        Deriv { dq, dw, dgimbal: rates, dgimbal_rate, dwheel, drotor_scale }
    }

    fn add(s: &State, d: &Deriv, h: f64) -> State {
        let mut g = s.gimbal_rad;
        let mut gr = s.gimbal_rate_rad_s;
        let mut rs = s.cmg_rotor_scale;
        for i in 0..MAX_GIMBALS {
            g[i] += h * d.dgimbal[i];
            gr[i] += h * d.dgimbal_rate[i];
            rs[i] += h * d.drotor_scale[i];
        }
        let mut wh = s.wheels;
        for (x, dx) in wh.iter_mut().zip(d.dwheel.iter()) {
            *x = x.add_scaled(dx, h);
        }
        State {
            q: s.q + d.dq * h,
            w: s.w + d.dw * h,
            gimbal_rad: g,
            gimbal_rate_rad_s: gr,
            wheels: wh,
            cmg_rotor_scale: rs,
        }
    }

    /// Forget the cached snapshots (after the environment changed).
    pub fn clear_env_cache(&mut self) {
        self.env_cache.clear();
    }

    /// The environment at time `t` (None without one), through the stage-time cache: the
    /// snapshot the sensors see at a control step is the one the last RK4 stage used.
    pub fn env_at(&mut self, t: f64) -> anyhow::Result<Option<EnvSnapshot>> {
        self.env_parts_at(t, Parts::ALL)
    }

    fn env_parts_at(&mut self, t: f64, parts: Parts) -> anyhow::Result<Option<EnvSnapshot>> {
        match self.env.as_mut() {
            Some(e) => Ok(Some(e.snapshot_cached(t, parts, &mut self.env_cache)?)),
            None => Ok(None),
        }
    }

    /// One classical RK4 step of length `h` from time `t` with the input held, the
    /// environment evaluated at each stage's time: `t` (stage 1), `t + h/2` (stages 2
    /// and 3), `t + h` (stage 4). Renormalises `q`. Without an environment this is
    /// exactly `rk4(t, s, u, h, None)`. The stages get what `deriv` uses: the orbit state,
    /// and the field only when a dipole is on board (else `m × B` is zero whatever `B`).
    pub fn rk4_env(&mut self, t: f64, s: &State, u: &Input, h: f64) -> anyhow::Result<State> {
        if self.env.is_none() {
            return Ok(self.rk4(t, s, u, h, None));
        }
        let parts = Parts { field: u.dipole_am2 != Vec3::zeros(), lvlh: false };
        let e0 = self.env_parts_at(t, parts)?;
        let e1 = self.env_parts_at(t + 0.5 * h, parts)?;
        let e2 = self.env_parts_at(t + h, parts)?;
        Ok(self.rk4_stages(t, s, u, h, [e0.as_ref(), e1.as_ref(), e2.as_ref()]))
    }

    /// One classical RK4 step of length `h` from time `t` with the input and the
    /// environment snapshot `env` held over the step (None: free space); renormalises
    /// `q`. Holding an orbit environment makes the step first order in `h`: use
    /// [`Self::rk4_env`] for that.
    pub fn rk4(&self, t: f64, s: &State, u: &Input, h: f64, env: Option<&EnvSnapshot>) -> State {
        self.rk4_stages(t, s, u, h, [env; 3])
    }

    /// RK4 with the environment at `t`, `t + h/2` and `t + h` given.
    fn rk4_stages(&self, t: f64, s: &State, u: &Input, h: f64, env: [Option<&EnvSnapshot>; 3]) -> State {
        let k1 = self.deriv(t, s, u, env[0]);
        let k2 = self.deriv(t + 0.5 * h, &Self::add(s, &k1, 0.5 * h), u, env[1]);
        let k3 = self.deriv(t + 0.5 * h, &Self::add(s, &k2, 0.5 * h), u, env[1]);
        let k4 = self.deriv(t + h, &Self::add(s, &k3, h), u, env[2]);
        let mut g = s.gimbal_rad;
        let mut gr = s.gimbal_rate_rad_s;
        let mut rs = s.cmg_rotor_scale;
        for i in 0..MAX_GIMBALS {
            g[i] += h / 6.0 * (k1.dgimbal[i] + 2.0 * k2.dgimbal[i] + 2.0 * k3.dgimbal[i] + k4.dgimbal[i]);
            gr[i] += h / 6.0
                * (k1.dgimbal_rate[i] + 2.0 * k2.dgimbal_rate[i] + 2.0 * k3.dgimbal_rate[i] + k4.dgimbal_rate[i]);
            if self.gimbal_stuck[i] {
                gr[i] = 0.0; // a seized gimbal is at rest: its servo restarts from 0 when freed
            }
            // Only a spin-down moves it: nominal rotors keep 1 to the bit.
            if self.rotor_decay_per_s[i] != 0.0 {
                rs[i] += h / 6.0
                    * (k1.drotor_scale[i] + 2.0 * k2.drotor_scale[i] + 2.0 * k3.drotor_scale[i] + k4.drotor_scale[i]);
            }
        }
        if let Some(c) = &self.cmg {
            c.clamp_angles(&mut g);
        }
        let mut wh = s.wheels;
        for i in 0..self.wheels.len().min(MAX_WHEELS) {
            wh[i] = wh[i]
                .add_scaled(&k1.dwheel[i], h / 6.0)
                .add_scaled(&k2.dwheel[i], h / 3.0)
                .add_scaled(&k3.dwheel[i], h / 3.0)
                .add_scaled(&k4.dwheel[i], h / 6.0);
            // Every term uses integer multiples of the rotor angle: wrap it.
            wh[i].rotor_angle_rad = wh[i].rotor_angle_rad.rem_euclid(std::f64::consts::TAU);
        }
        let q = s.q + (k1.dq + (k2.dq + k3.dq) * 2.0 + k4.dq) * (h / 6.0);
        let w = s.w + (k1.dw + (k2.dw + k3.dw) * 2.0 + k4.dw) * (h / 6.0);
        State { q: q.normalize(), w, gimbal_rad: g, gimbal_rate_rad_s: gr, wheels: wh, cmg_rotor_scale: rs }
    }

    /// Total angular momentum in the inertial frame, N m s (conserved without T_ext).
    pub fn angular_momentum_inertial(&self, s: &State) -> Vec3 {
        dcm_body_to_ref(&s.q) * (self.inertia * s.w + self.actuator_momentum(s))
    }

    /// Rotational kinetic energy of body and wheels, J (conserved with gimbals at rest and
    /// torque-free wheels): `½ ωᵀ J ω + Σ h_a² / (2 I_w)`.
    pub fn kinetic_energy(&self, s: &State) -> f64 {
        let wheels: f64 = self
            .wheels
            .iter()
            .zip(s.wheels.iter())
            .map(|(p, ws)| ws.h_abs_nms * ws.h_abs_nms / (2.0 * p.inertia_kgm2))
            .sum();
        0.5 * s.w.dot(&(self.inertia * s.w)) + wheels
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::attitude::quat_from_euler;
    use acs_flight::math::EulerSeq;
    use wheel::{WheelParams, WheelState};

    fn craft() -> Spacecraft {
        let i = Matrix3::new(3.1, 0.05, -0.02, 0.05, 3.4, 0.03, -0.02, 0.03, 5.8);
        Spacecraft::new(i, Some(CmgCluster::pyramid(54.73f64.to_radians(), 0.623, 1e3, None))).unwrap()
    }

    fn state() -> State {
        let mut g = [0.0; MAX_GIMBALS];
        g[..4].copy_from_slice(&[0.3, -0.7, 1.1, 0.2]);
        State {
            q: quat_from_euler([0.2, -0.1, 0.5], EulerSeq::Zyx321),
            w: Vec3::new(0.05, -0.08, 0.12),
            gimbal_rad: g,
            gimbal_rate_rad_s: [0.0; MAX_GIMBALS],
            wheels: [WheelState::default(); MAX_WHEELS],
            cmg_rotor_scale: NOMINAL_ROTORS,
        }
    }

    /// CMG pyramid plus the four-wheel pyramid of paper 001 (ideal wheels), wheels spinning.
    fn craft_with_wheels() -> (Spacecraft, State) {
        let mut sc = craft();
        let (a, b) = (45f64.to_radians(), 54.73f64.to_radians());
        let (ca, sa, cb, sb) = (a.cos(), a.sin(), b.cos(), b.sin());
        for axis in [[ca * sb, sa * sb, cb], [-sa * sb, ca * sb, cb], [-ca * sb, -sa * sb, cb], [sa * sb, -ca * sb, cb]]
        {
            sc.wheels.push(WheelParams { spin_axis: axis, ..WheelParams::ideal(0.2, 600.0, 0.01) });
        }
        let mut s = state();
        for (i, speed) in [100.0, -50.0, 30.0, 250.0].into_iter().enumerate() {
            s.wheels[i] = WheelState::spinning(&sc.wheels[i], speed, &s.w.into());
        }
        (sc, s)
    }

    #[test]
    fn torque_free_body_with_wheels_and_cmgs_conserves_momentum_and_energy_for_hours() {
        // 3 h. The drift is RK4 truncation: it must be small and fall at 4th order with dt.
        let drift = |dt: f64| {
            let (sc, mut s) = craft_with_wheels();
            let (h0, e0) = (sc.angular_momentum_inertial(&s), sc.kinetic_energy(&s));
            let u = Input::default();
            for _ in 0..(10_800.0 / dt) as usize {
                s = sc.rk4(0.0, &s, &u, dt, None);
            }
            let (h1, e1) = (sc.angular_momentum_inertial(&s), sc.kinetic_energy(&s));
            ((h1 - h0).norm() / h0.norm(), (e1 - e0).abs() / e0)
        };
        let (h_a, e_a) = drift(0.05);
        let (h_b, e_b) = drift(0.025);
        eprintln!("3 h drift: momentum {h_a:e} / {h_b:e}, energy {e_a:e} / {e_b:e} (dt 0.05 / 0.025 s)");
        assert!(h_a < 1e-6 && e_a < 1e-6, "{h_a:e} {e_a:e}");
        assert!(h_b < h_a / 10.0 && e_b < e_a / 10.0, "not converging at 4th order");
    }

    #[test]
    fn wheel_torques_exchange_momentum_with_the_body_and_conserve_the_total() {
        let (sc, mut s) = craft_with_wheels();
        let h0 = sc.angular_momentum_inertial(&s);
        let mut u = Input::default();
        u.wheel_torque_cmd_nm[..4].copy_from_slice(&[0.05, -0.03, 0.02, -0.04]);
        for _ in 0..6_000 {
            s = sc.rk4(0.0, &s, &u, 0.01, None);
        }
        let h1 = sc.angular_momentum_inertial(&s);
        assert!((h1 - h0).norm() < 1e-9 * h0.norm(), "drift {:e}", (h1 - h0).norm() / h0.norm());
        // 60 s at 0.05 N m changed wheel 1's absolute momentum by 3 N m s.
        let w0 = WheelState::spinning(&sc.wheels[0], 100.0, &state().w.into());
        assert!((s.wheels[0].h_abs_nms - w0.h_abs_nms - 3.0).abs() < 1e-9);
    }

    #[test]
    fn torque_free_with_fixed_gimbals_conserves_momentum_and_energy_over_1000_s() {
        let sc = craft();
        let mut s = state();
        let (h0, e0) = (sc.angular_momentum_inertial(&s), sc.kinetic_energy(&s));
        let u = Input::default();
        for _ in 0..100_000 {
            s = sc.rk4(0.0, &s, &u, 0.01, None);
        }
        let (h1, e1) = (sc.angular_momentum_inertial(&s), sc.kinetic_energy(&s));
        // RK4 at 100 Hz on a ~0.15 rad/s tumble: truncation error ~1e-12 per step.
        assert!((h1 - h0).norm() < 1e-9 * h0.norm(), "momentum drift {:e}", (h1 - h0).norm() / h0.norm());
        assert!((e1 - e0).abs() < 1e-9 * e0, "energy drift {:e}", (e1 - e0).abs() / e0);
    }

    #[test]
    fn moving_gimbals_exchange_momentum_but_conserve_the_total() {
        let sc = craft();
        let mut s = state();
        let h0 = sc.angular_momentum_inertial(&s);
        let mut u = Input::default();
        u.gimbal_rate_cmd_rad_s[..4].copy_from_slice(&[0.3, -0.2, 0.1, 0.4]);
        for _ in 0..100_000 {
            s = sc.rk4(0.0, &s, &u, 0.01, None);
        }
        let h1 = sc.angular_momentum_inertial(&s);
        assert!((h1 - h0).norm() < 1e-9 * h0.norm(), "drift {:e}", (h1 - h0).norm() / h0.norm());
        // The gimbals really moved (1000 s at 0.3 rad/s): the exchange was not trivial.
        assert!((s.gimbal_rad[0] - 0.3 - 300.0).abs() < 1e-9);
    }

    #[test]
    fn gimbal_motion_from_rest_produces_the_eq4_torque() {
        // From rest, ω = 0: the body sees T = -J δ̇ (eq 4), so I ω̇ = -J δ̇ at t = 0.
        let sc = craft();
        let mut s = state();
        s.w = Vec3::zeros();
        let mut u = Input::default();
        u.gimbal_rate_cmd_rad_s[..4].copy_from_slice(&[0.5, 0.0, -0.25, 0.1]);
        let dt = 1e-4;
        let s1 = sc.rk4(0.0, &s, &u, dt, None);
        let t_expected = sc.actuator_torque(&s, &u);
        let c = sc.cmg.as_ref().unwrap();
        let jd = c.momentum_rate(&s.gimbal_rad, &u.gimbal_rate_cmd_rad_s);
        assert!((t_expected + jd).norm() < 1e-15, "T = -J δ̇ at ω = 0");
        let t_measured = sc.inertia * (s1.w - s.w) / dt;
        assert!((t_measured - t_expected).norm() < 1e-3 * t_expected.norm(), "{t_measured:?} vs {t_expected:?}");
    }
}
