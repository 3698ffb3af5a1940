//! The recorded row of one control step, in the column order of [`Layout::names`].

use super::Simulation;
use crate::attitude::{Quat, Vec3, error_angle_and_vector, euler_from_quat, rotate_ref_to_body};
use crate::plant::wheel::{WheelDeriv, WheelOutput};
use crate::plant::{Input, MAX_WHEELS, TorqueReport};
#[cfg(doc)]
use crate::recorder::columns::Layout;
use crate::recorder::segments::Segments;
use acs_flight::link::{ActuatorCommand, law_slots};

/// What one control step saw, for the recorded row.
pub(super) struct StepView<'a> {
    pub(super) t: f64,
    pub(super) cmd: &'a ActuatorCommand,
    pub(super) ticks: u32,
    pub(super) err_deg: f64,
    pub(super) q_frame: Quat,
    /// The target's Euler angles relative to `q_frame`, deg.
    pub(super) target_euler_deg: [f64; 3],
    pub(super) input: &'a Input,
    pub(super) dipole_cmd: [f64; 3],
    /// The wheels evaluated at the step (their outputs are recorded, and they make the
    /// applied torque).
    pub(super) wheels: &'a [(WheelDeriv, WheelOutput); MAX_WHEELS],
    pub(super) n_wheels: usize,
}

impl Simulation<'_> {
    /// Builds the recorded row of one step (column order: [`Layout::names`]).
    pub(super) fn fill_row(&mut self, v: &StepView) {
        let (state, cmd, l) = (&self.state, v.cmd, &self.layout);
        let tq = self.craft.torques_with(v.t, state, v.input, self.snap.as_ref(), v.wheels);
        let row = &mut self.row;
        row.clear();
        row.push(v.t);
        row.extend([state.q.i, state.q.j, state.q.k, state.q.w]);
        row.extend(euler_from_quat(&(v.q_frame.conjugate() * state.q), self.target.seq).map(f64::to_degrees));
        row.extend(v.target_euler_deg);
        row.extend(state.w.iter());
        row.extend(cmd.torque_demand_nm.iter().map(|x| *x as f64));
        row.extend(cmd.torque_realised_nm.iter().map(|x| *x as f64));
        row.extend((tq.actuators_nm + tq.magnetic_nm + tq.thrusters_nm).iter());
        row.push(v.err_deg);
        row.push(cmd.status as f64);
        let ipt = self.info.as_ref().and_then(|i| i.instructions_per_tick);
        row.push(ipt.map_or(f64::NAN, |f| v.ticks as f64 * f));
        if l.adaptive_gains {
            row.extend(law_slots::dmcs_feedforward_gain(&cmd.law_telemetry).map(f64::from));
        }
        if l.mode {
            row.push(cmd.mode as f64);
        }
        if l.flight_error {
            row.push((cmd.attitude_error_rad as f64).to_degrees());
        }
        if l.cmg {
            row.extend(state.gimbal_rad[..4].iter().map(|x| x.to_degrees()));
            row.extend(cmd.gimbal_rate_cmd_rad_s.iter().map(|x| *x as f64));
            row.push(self.craft.cmg.as_ref().map_or(f64::NAN, |c| c.singularity_measure(&state.gimbal_rad)));
            row.push(cmd.steering_alpha as f64);
        }
        for (_, o) in &v.wheels[..v.n_wheels] {
            let rpm = o.speed_rad_s * 30.0 / std::f64::consts::PI;
            row.extend([rpm, o.current_a, o.voltage_v, o.power_w, o.friction_nm, o.delivered_torque_nm]);
        }
        self.fill_tail(v, &tq);
        if self.layout.guidance {
            self.fill_guidance(v.cmd);
        }
        if let Some(k) = self.keepout.as_mut() {
            let g = crate::sensors::suite::exclusion_geometry(v.t, &self.craft, self.snap.as_ref());
            k.row(v.t, &self.state.q, g.as_ref(), &v.cmd.guidance, &mut self.row);
        }
        if self.layout.faults {
            self.row.push(f64::from(crate::faults::active_mask(&self.faults.list, v.t)));
        }
        if self.layout.timeline {
            self.row.push(f64::from(self.timeline.report.in_force));
        }
        if self.layout.fdir_wheels > 0 {
            let f = &v.cmd.fdir;
            self.row.push(f64::from(f.failed_wheels));
            let residuals = f.wheel_residual_nm.iter().take(self.layout.fdir_wheels);
            self.row.extend(residuals.map(|r| if f.wheel_judged { f64::from(*r) } else { f64::NAN }));
            self.row.push(if f.wheel_judged { f64::from(f.wheel_threshold_nm) } else { f64::NAN });
        }
        if self.layout.fdir_magnetometer {
            // Not judged (no model magnitude yet, a repeated sample): NaN, not a zero residual.
            let f = &v.cmd.fdir;
            let judged = f.mag_threshold_t > 0.0;
            let value = |x: f32| if judged { f64::from(x) } else { f64::NAN };
            self.row.extend([value(f.mag_residual_t), value(f.mag_threshold_t)]);
        }
        if self.layout.fdir_gnss {
            // Not judged (no fix this step, no accepted fix before it, failed): NaN.
            let f = &v.cmd.fdir;
            let judged = f.gnss_threshold_m > 0.0;
            let value = |x: f32| if judged { f64::from(x) } else { f64::NAN };
            self.row.extend([value(f.gnss_residual_m), value(f.gnss_threshold_m)]);
            self.row.extend([value(f.gnss_velocity_residual_m_s), value(f.gnss_velocity_threshold_m_s)]);
        }
    }

    /// The guidance group ([`crate::recorder::columns::GUIDANCE`]): the truth's pointing
    /// errors and view of the site, the flight's guidance telemetry, the true orbit state,
    /// Sun direction and Earth angle.
    fn fill_guidance(&mut self, cmd: &ActuatorCommand) {
        let nan = f64::NAN;
        let row = &mut self.row;
        let tr = self.truth_row;
        let e = tr.and_then(|r| r.errors);
        row.push(e.map_or(nan, |e| e.primary_rad.to_degrees()));
        row.push(e.map_or(nan, |e| e.secondary_rad.to_degrees()));
        let g = &cmd.guidance;
        let [x, y, z, w] = g.q_cmd_xyzw.map(f64::from);
        let q_flight = Quat::new(w, x, y, z);
        let guidance_error = match (tr, q_flight.norm()) {
            (Some(r), n) if n > 0.5 => error_angle_and_vector(&(q_flight / n), &r.q_cmd).0.to_degrees(),
            _ => nan,
        };
        row.push(guidance_error);
        row.extend(e.map_or([nan; 3], |e| e.target_body.into()));
        let step = tr.map(|r| r.step);
        row.push(step.and_then(|s| s.elevation_rad).map_or(nan, f64::to_degrees));
        row.push(step.and_then(|s| s.visible).map_or(nan, |v| f64::from(u8::from(v))));
        row.push(self.segments.as_ref().and_then(Segments::current).map_or(nan, |i| i as f64));
        let parallel = step.and_then(|s| s.ideal).and_then(|i| i.axes).map(|a| a.parallel);
        row.push(parallel.map_or(nan, |p| f64::from(u8::from(p))));
        row.extend([f64::from(g.flags), f64::from(g.switches), f64::from(g.parallel_events)]);
        row.extend(g.rate_cmd_rad_s.map(f64::from));
        row.extend(g.accel_cmd_rad_s2.map(f64::from));
        let sky = tr.and_then(|r| r.sky);
        row.extend(sky.map_or([nan; 3], |s| s.r_m.into()));
        row.extend(sky.map_or([nan; 3], |s| s.v_m_s.into()));
        let sun = sky.and_then(|s| (s.sun_m - s.r_m).try_normalize(0.0));
        row.extend(sun.map_or([nan; 3], Into::into));
        row.push(tr.map_or(nan, |r| r.earth_angle_rad));
    }

    /// The actuator-family and environment groups at the end of the row.
    fn fill_tail(&mut self, v: &StepView, tq: &TorqueReport) {
        let (state, l, act, row) = (&self.state, &self.layout, &self.act, &mut self.row);
        if l.magnetorquers {
            row.extend(v.dipole_cmd);
            row.extend(act.rod_dipole);
        }
        if l.thrusters > 0 {
            row.push(u32::from(v.cmd.thruster_on) as f64);
            row.push(act.thr_state.total_propellant_kg());
            row.push(act.thr_state.pulses.iter().sum::<u32>() as f64);
            row.extend(v.cmd.thruster_level.iter().take(act.n_thr).map(|x| *x as f64));
        }
        if l.field {
            let b =
                self.snap.and_then(|s| s.b_ref_t).map_or(Vec3::repeat(f64::NAN), |b| rotate_ref_to_body(&state.q, &b));
            row.extend(b.iter());
        }
        if l.env_torques {
            let e = &tq.env;
            let external = e.external + self.craft.external_torque_nm;
            for v in [e.gravity_gradient, e.drag, e.srp, tq.magnetic_nm, tq.rig_nm, external] {
                row.extend(v.iter());
            }
        }
        if l.estimation {
            let nan = f64::NAN;
            let e = self.estimation.last();
            row.extend(e.map_or([nan; 5], |e| {
                [e.error_deg, e.sigma_deg, e.bias_error_deg_h, e.bias_sigma_deg_h, e.nees.unwrap_or(nan)]
            }));
            let (rejected, resets) = self.estimation.counters();
            row.extend([f64::from(rejected), f64::from(resets)]);
            row.extend(self.estimation.sample_columns());
        }
        if l.momentum {
            let h = self.craft.actuator_momentum(state);
            row.extend(h.iter());
            row.extend((crate::attitude::dcm_body_to_ref(&state.q) * h).iter());
            row.push(h.norm());
            let b = self.snap.and_then(|s| s.b_ref_t).map_or(Vec3::zeros(), |b| rotate_ref_to_body(&state.q, &b));
            row.extend(Vec3::from(act.rod_dipole).cross(&b).iter());
            row.push(f64::from(v.cmd.momentum_events));
        }
        if l.eclipse {
            let shadow = match (self.snap.and_then(|s| s.orbit.map(|(r, _)| (s.t_s, r))), self.craft.env.as_ref()) {
                (Some((t_s, r)), Some(env)) => f64::from(u8::from(env.in_eclipse(t_s, &r))),
                _ => f64::NAN,
            };
            row.push(shadow);
        }
    }
}
