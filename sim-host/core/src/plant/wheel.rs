//! Reaction-wheel plant model after paper 001 (Samadi Khoshkho, Mortazavi-Bek, Fani Saberi,
//! "Satellite adaptive attitude control based on DMCS in the presence of an accurate
//! reaction-wheel model"), figs 2-5, eqs 2-30, table 1. Host side, `f64`, pure derivatives
//! (the simulator owns the single RK4 over body + wheel states; this module never integrates).
//!
//! # Coupling (eqs 2-5, 23)
//! State `h_abs_nms` = absolute axial momentum `h_a = I_w aᵀω + I_w ω_w` (eq 4). Relative speed
//! `ω_w = h_a/I_w - aᵀω`. `ḣ_a` = net axial torque on the rotor = `u_out` (eq 24); the body
//! feels `-a ḣ_a` (eq 5, `delivered_torque_nm = -ḣ_a`) plus the imbalance torque (eqs 13, 16-20).
//! Eq 23, `ω̇_w = J_w⁻¹(u_out - I_w Cᵀω̇)`, is the same law written for the relative speed:
//! `I_w ω̇_w = ḣ_a - I_w aᵀω̇`. Because `ḣ_a = u_out` depends only on states and ω, never on
//! `ω̇`, there is no algebraic loop; `body_accel` is used only for the `speed_accel_rad_s2` output.
//!
//! # Accurate model
//! * eq 25 + fig 5 speed loop: `I_cmd = T_cmd/K_f - K_c (ω_w - ω_ref)`, `ω̇_ref = T_cmd/I_w`
//!   (`ω_ref` = paper's `ω_out`, the speed the wheel would have if the command were delivered;
//!   the paper's `+G(s)` must be read as negative feedback, `G = -K_c`, or the loop is unstable).
//!   This gives eq 10, `u_out/T_e = -s/(s + K_f K_c/I_w)`: low-frequency friction is rejected.
//!   Anti-windup (not in the paper): `ω̇_ref = (K_f I_applied + K_f K_c e)/I_w`, equal to
//!   `T_cmd/I_w` when no limit is active, so the loop error obeys `ė = -p e - T_e/I_w - aᵀω̇`
//!   in every regime. The tachometer measures relative speed (physical reading of eq 25).
//! * current loop (fig 4): `G_i(s) = 1` as in the paper (pole assumed far away), so the motor
//!   current is algebraic: no electrical state, no stiffness from it.
//! * limits on the current, applied in this order (the last one is hard):
//!   eq 27 speed limiter `sgn(ω_w) I ≤ (V_max_w - K_f|ω_w|)/k_b`, `V_max_w = K_f ω_max`
//!   (only the accelerating direction is limited; above ω_max it forces braking: the paper's
//!   `|I| ≤ |…|` would also cap braking and allow speeding-up beyond ω_max);
//!   eq 28/29 supply voltage `|R I + K_f ω_w| ≤ V_max_m` (signed reading of eq 29; back-EMF
//!   speed `V_max_m/K_f`); current `|I| ≤ I_max`, torque `|K_f I| ≤ T_max`;
//!   eq 30 power `p_q + R I² + a_i|I|V_max_m + K_f ω_w I ≤ p_max` (solved exactly for |I|).
//! * eq 24 `u_out = K_f I - T_e`, eq 14 `T_e = T_f + T_v + t_rb + t_r`, eq 15 `T_v = λ ω_w`,
//!   eq 21 `t_rb = C_s sin(φ + φ0)`, eq 22 `t_r = B sin(3 P φ)` (φ = rotor angle relative to
//!   the body, `φ̇ = ω_w`; the paper's θ in eq 22 is read as the same rotor angle).
//! * eq 23 Dahl friction `Ṫ_f = β ω_w (T_f0 - T_f s)|T_f0 - T_f s|`, `s = tanh(ω_w/ω_s)` (the
//!   paper's `tanh(ω/(1-α))`, `ω_s = 1-α`). Identical to the printed `β ω (T_f s - T_f0)²` on
//!   the physical set `|T_f| ≤ T_f0`, but restoring outside it (the printed square pushes an
//!   RK4 overshoot away from `T_f0` and then diverges). Converges to `T_f0 sgn ω`, and
//!   `|Ṫ_f| ≤ 4 β T_f0² |ω_w|` (bounded: no chattering at zero speed).
//! * eqs 16-20 imbalance: `U_d = D_d ω_w² r̂(φ+φ0)`, `f_s = D_s ω_w² r̂(φ+φ0)`, `U_s = R_w × f_s`,
//!   `r̂(ψ) = cos ψ â1 + sin ψ â2` rotating in the plane normal to the spin axis. The printed
//!   eqs 16/18 put the same `sin` on both axes (a non-rotating vector); read as cos/sin.
//!
//! # Parameters of [`WheelParams::paper001`] (reason for each choice)
//! | symbol | value | reason |
//! |---|---|---|
//! | `I_w` | 0.086 kg m² | table value lost in OCR; the text uses 0.086 for `K_c`. 54 N m s at 6000 rpm fits a 400-700 kg m² spacecraft |
//! | `K_f` (=`K_e`) | 0.75/38.85 = 0.019305 N m/A | table 0.175 and text 0.0175 disagree. 0.175 makes 38.85 A meaningless (0.75 N m at 4.3 A); 0.0175 never reaches 0.75 N m (0.68 N m at 38.85 A). 0.0193 makes all four limits consistent: `K_f I_max = T_max` and `K_f ω_max I_max = T_max ω_max = 471 W ≈ 470 W = p_max` |
//! | `R` | 0.08 Ω | printed 0.8 Ω. With 0.8, `I²R` at 38.85 A is 1207 W > 470 W, so the power limit would cap the wheel at 24 A / 0.47 N m even at standstill and the 0.75 N m / 38.85 A limits could never be reached. Read as the same dropped-zero damage as `K_f` (0.0175 → 0.175); 0.08 gives 121 W copper loss at full torque and power-limited torque only above ≈4460 rpm. Set `resistance_ohm = 0.8` to get the printed value |
//! | `V_max_m` | 27 V | not printed; "1 V below the supply", supply taken as a 28 V bus. Back-EMF speed 1399 rad/s > ω_max, so eq 27 acts before eq 28 |
//! | `ω_max` | 6000 rpm = 628.3 rad/s | text |
//! | `T_max`, `I_max`, `p_max` | 0.75 N m, 38.85 A, 470 W | text |
//! | `p_q`, `a_i` | 0 W, 0 | not printed (eq 30 symbols only); zero is neutral. Tests also run non-zero values |
//! | `k_b` | 0.005 V/A | not printed. "large gain": current ramps from `I_max` to 0 over the last 10 rad/s (1.6 %) below ω_max; time constant `I_w k_b/K_f²` = 1.15 s (not stiff) |
//! | `K_c` | 2.5 I_w/K_f = 11.14 A s/rad | eq 11 `K_f K_c/I_w > 2.5`, taken at the bound (pole 2.5 rad/s: 10 time constants = the paper's 4 s rejection time). The printed `K_c > 0.01` is inconsistent with any printed `K_f`, `I_w` |
//! | `λ` | 3e-4 N m s/rad | table |
//! | `T_f0`, `β` | 0.04 N m, 4 (N m)⁻¹ rad⁻¹ | table; `β` is read in the units of the printed eq 23 (equivalent normalised Dahl rest stiffness `β T_f0²` = 0.0064 N m/rad) |
//! | `ω_s` (= 1-α) | 0.01 rad/s | α not printed; any value ≪ operating speeds |
//! | `C_s`, `B` | 0.02, 0.02 N m | table gives only `t_rb + t_r = 4e-2`: split equally |
//! | `P` | 4 | not printed (ripple at 12× wheel rate) |
//! | `D_d`, `D_s` | 3e-6 kg m², 7.2e-6 kg m | table (Persian "7/2" = 7.2) |
//! | `φ0` | 0 | not printed |
//!
//! Spin axis, position and `φ0` are per-wheel and must be set by the simulator (defaults: +z, origin).
//!
//! # Actuator lag and delay (both models, both off by default; issue 25)
//! * `torque_lag_s` = τ_a > 0: the torque command reaching the model (the `T_cmd` above, before
//!   every limit) is the state `applied_torque_nm` of the first-order lag
//!   `τ_a Ṫ_a = T_cmd - T_a` (initially 0), integrated as a state inside the simulator's single
//!   RK4 (not in closed form): per step the lag's factor is RK4's 4th-order polynomial of
//!   `e^{-h/τ_a}`, relative error ≈ (h/τ_a)⁵/120 (2e-8 at h = τ_a/10). `1/τ_a` joins
//!   [`WheelParams::fastest_rate_per_s`], so the RK4 stability check covers it.
//!   τ_a = 0 leaves the state at exactly 0 and the command untouched (same bits as before).
//! * `torque_delay_s` = Δ ≥ 0: a pure delay of the command, applied by the simulator (not in
//!   this module, [`TorqueDelayLine`]) per dynamics step: the command that reaches the wheel over
//!   `[t_j, t_j + h)` is the one that was applied `n = round(Δ/h)` dynamics steps earlier (zero
//!   before the first). Δ is thus quantised to the nearest whole dynamics step h (control
//!   period / `dynamics_substeps`; error ≤ h/2): exact when Δ is a multiple of h (e.g. half a
//!   control period with an even number of substeps).
//!
//! # Step size
//! Rates (1/s) of the accurate model: speed loop `K_f K_c/I_w` = 2.5; speed limiter
//! `K_f²/(k_b I_w)` = 0.87; winding `K_f²/(R I_w)` = 0.054; viscous `λ/I_w` = 0.0035; Dahl
//! worst case `4 β T_f0 ω_top` = 402 at 6000 rpm (Jacobian bound at `|T_f0 - T_f s| = 2 T_f0`).
//! Fastest time constant 2.5 ms; [`WheelParams::max_stable_step_s`] = 2.5/rate = 6.2 ms (RK4
//! real-axis limit 2.785). Bearing/ripple/imbalance terms are forcing at up to 12× the wheel
//! rate (1.2 kHz at 6000 rpm); they do not affect stability, but resolving them needs
//! [`WheelParams::harmonic_step_s`]. Coarser steps alias them (bounded effect `≤ (C_s+B) dt`
//! on `h_a` per step).
//!
//! # Standing current at zero speed
//! A wheel whose speed reaches ~0 can stick and still draw current (wheel 3 of
//! `scenarios/paper001/wheel-slew.toml` after 250 s: ~0 rpm, 4.06 A, 1.32 W). Nothing in the
//! model is wrong there; three of its features combine. At rest the Dahl state keeps its value
//! (`Ṫ_f ∝ ω_w`, presliding memory; the slow creep inside the tanh band `|ω_w| ≪ ω_s` even lets
//! it pass `T_f0` by a few per cent: the state is then a linear spring `β T_f0²` in rotor angle),
//! and eqs 21-22 make the bearing and ripple torques functions of the rotor angle, so at rest they
//! are a static torque of up to `C_s + B`. Together they can hold up to ≈ `T_f0 + C_s + B` =
//! 0.08 N m. The speed loop of eq 25 is proportional only: while sliding it lags its reference by
//! `T_e/(K_f K_c)` (0.19 rad/s under `T_f0`), and when the rotor sticks the reference keeps that
//! lead plus every share of the command the stuck wheel does not deliver. At rest (`ω_w ≈ 0`,
//! `ḣ_a ≈ 0`) eqs 24, 25 and 30 give
//! `I = K_c (ω_ref - ω_w) + T_cmd/K_f = (T_f + λω_w + C_s sin(φ+φ0) + B sin(3Pφ))/K_f`,
//! `P = p_q + R I² + a_i V_max_m |I| + K_f ω_w I ≈ R I²`: in the slew at 1200 s
//! `(0.04075 + 0.03772)/0.019305 = 4.065 A` (lead 0.365 rad/s = 3.5 rpm, `K_c` = 11.14 A s/rad),
//! `0.08 × 4.065² = 1.32 W` of copper loss, recorded 4.0649 A and 1.3219 W. When the lead needs
//! more than the angle can hold, the rotor slips (under 1.5 rpm) to the next holding angle and
//! sticks again; the lead, hence the current, survives the slip (no position memory in the loop).
//! `sim-host/core/tests/wheel_model.rs#standing_current_at_zero_speed_is_the_held_speed_loop_error`
//! checks this on every recorded row.
use crate::vec3::{cross, dot, norm};
use serde::{Deserialize, Serialize};

#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize)]
pub enum Fidelity {
    /// Torque limit + speed limit only (linear torque fade over `ideal_speed_band_rad_s` below ω_max).
    Ideal,
    /// Paper 001 figs 2-5, eqs 10-30.
    Accurate,
}

#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct WheelParams {
    pub fidelity: Fidelity,
    /// `I_w`, axial rotor inertia.
    pub inertia_kgm2: f64,
    /// `a`, unit spin axis in body axes (a column of C, eq 9).
    pub spin_axis: [f64; 3],
    /// `R_w`, wheel position w.r.t. the spacecraft centre of mass, body axes (eq 20).
    pub position_m: [f64; 3],
    pub max_torque_nm: f64,
    pub max_speed_rad_s: f64,
    /// Ideal only: width of the torque fade below `max_speed_rad_s`.
    pub ideal_speed_band_rad_s: f64,
    pub max_current_a: f64,
    /// `p_max` (eq 30).
    pub max_power_w: f64,
    /// `p_q` (eq 30).
    pub quiescent_power_w: f64,
    /// `a_i` (eq 30), control-circuit loss coefficient.
    pub control_loss_coeff: f64,
    /// `K_f`, torque constant = back-EMF constant (V s/rad).
    pub torque_constant_nm_per_a: f64,
    /// `R` (eqs 29, 30).
    pub resistance_ohm: f64,
    /// `V_max_m` (eqs 28-30).
    pub motor_voltage_max_v: f64,
    /// Enables eq 27.
    pub speed_limiter: bool,
    /// `k_b` (eq 27), V/A.
    pub speed_limiter_gain_ohm: f64,
    /// `K_c` (eqs 10, 11, 25), A s/rad. 0 = open loop (no friction compensation).
    pub speed_loop_gain: f64,
    /// `λ` (eq 15), N m s/rad.
    pub viscous_nms: f64,
    /// `T_f0` (eq 23).
    pub coulomb_nm: f64,
    /// `β` (eq 23), 1/(N m rad).
    pub dahl_beta: f64,
    /// `1 - α` of the tanh sign approximation (eq 23), rad/s.
    pub sign_smoothing_rad_s: f64,
    /// `C_s` (eq 21).
    pub bearing_nm: f64,
    /// `B` (eq 22).
    pub ripple_nm: f64,
    /// `P` (eq 22), number of motor poles.
    pub motor_poles: f64,
    /// `φ0` (eqs 16, 18, 21).
    pub phase_rad: f64,
    /// `D_d = m r d` (eq 17), kg m².
    pub dyn_imbalance_kgm2: f64,
    /// `D_s = m r` (eq 19), kg m.
    pub static_imbalance_kgm: f64,
    /// `τ_a`, first-order lag of the torque command (0 = none, see the module doc), s.
    pub torque_lag_s: f64,
    /// `Δ`, pure delay of the torque command, applied by the simulator per dynamics step
    /// (0 = none, see the module doc), s.
    pub torque_delay_s: f64,
}

#[derive(Debug, Clone, Copy, Default, PartialEq, Serialize, Deserialize)]
pub struct WheelState {
    /// `h_a` (eq 4), absolute axial momentum.
    pub h_abs_nms: f64,
    /// `φ`, rotor angle relative to the body.
    pub rotor_angle_rad: f64,
    /// `T_f` (eq 23).
    pub dahl_friction_nm: f64,
    /// `ω_out` of eq 25: reference speed of the speed loop (relative). Initialise it to the
    /// relative wheel speed (see [`WheelState::spinning`]) or the loop slews to the mismatch.
    pub speed_ref_rad_s: f64,
    /// `T_a`, the lagged torque command (only with `torque_lag_s > 0`; else stays 0).
    pub applied_torque_nm: f64,
}

#[derive(Debug, Clone, Copy, Default, PartialEq, Serialize, Deserialize)]
pub struct WheelDeriv {
    pub dh_abs_nm: f64,
    pub drotor_angle: f64,
    pub ddahl: f64,
    pub dspeed_ref: f64,
    pub dapplied_torque: f64,
}

/// Per-wheel outputs. In `Ideal` fidelity current, voltage, friction, disturbance and imbalance
/// are zero and `power_w` is the mechanical power `ω_w ḣ_a`.
#[derive(Debug, Clone, Copy, Default, PartialEq, Serialize, Deserialize)]
pub struct WheelOutput {
    /// `ω_w`, relative to the body.
    pub speed_rad_s: f64,
    /// `ω̇_w` (eq 23), uses `body_accel`.
    pub speed_accel_rad_s2: f64,
    pub current_a: f64,
    /// Motor terminal voltage `R I + K_f ω_w`.
    pub voltage_v: f64,
    /// Electrical power of eq 30 (`p_q` included; negative when regenerating). Ideal: mechanical.
    pub power_w: f64,
    /// `K_f I`.
    pub motor_torque_nm: f64,
    /// `T_f + T_v`.
    pub friction_nm: f64,
    /// `t_rb + t_r`.
    pub disturbance_nm: f64,
    /// Axial torque on the body `-ḣ_a`.
    pub delivered_torque_nm: f64,
    /// Speed-loop error `ω_w - ω_ref`.
    pub speed_error_rad_s: f64,
    /// `f_s` on the body, body axes (eq 18).
    pub imbalance_force_n: [f64; 3],
    /// `U_d + R_w × f_s` on the body, body axes (eqs 16, 20).
    pub imbalance_torque_nm: [f64; 3],
}

/// Largest `x ≥ 0` with `r x² + b x - c ≤ 0` (`r > 0`, `c ≥ 0`), cancellation-free.
fn quad_root(r: f64, b: f64, c: f64) -> f64 {
    let sq = (b * b + 4.0 * r * c).sqrt();
    if b >= 0.0 { 2.0 * c / (b + sq) } else { (sq - b) / (2.0 * r) }
}

impl WheelParams {
    /// Paper 001 wheel (see the module table for every OCR fix / assumption).
    pub fn paper001() -> Self {
        let iw = 0.086;
        let kf = 0.75 / 38.85;
        WheelParams {
            fidelity: Fidelity::Accurate,
            inertia_kgm2: iw,
            spin_axis: [0.0, 0.0, 1.0],
            position_m: [0.0; 3],
            max_torque_nm: 0.75,
            max_speed_rad_s: 6000.0 * std::f64::consts::PI / 30.0,
            ideal_speed_band_rad_s: 2.0 * std::f64::consts::PI,
            max_current_a: 38.85,
            max_power_w: 470.0,
            quiescent_power_w: 0.0,
            control_loss_coeff: 0.0,
            torque_constant_nm_per_a: kf,
            resistance_ohm: 0.08,
            motor_voltage_max_v: 27.0,
            speed_limiter: true,
            speed_limiter_gain_ohm: 0.005,
            speed_loop_gain: 2.5 * iw / kf,
            viscous_nms: 3e-4,
            coulomb_nm: 4e-2,
            dahl_beta: 4.0,
            sign_smoothing_rad_s: 0.01,
            bearing_nm: 0.02,
            ripple_nm: 0.02,
            motor_poles: 4.0,
            phase_rad: 0.0,
            dyn_imbalance_kgm2: 3e-6,
            static_imbalance_kgm: 7.2e-6,
            torque_lag_s: 0.0,
            torque_delay_s: 0.0,
        }
    }

    /// Ideal wheel: clipped torque, no torque past `max_speed` (fade over the last 1 %).
    pub fn ideal(max_torque_nm: f64, max_speed_rad_s: f64, inertia: f64) -> Self {
        WheelParams {
            fidelity: Fidelity::Ideal,
            inertia_kgm2: inertia,
            max_torque_nm,
            max_speed_rad_s,
            ideal_speed_band_rad_s: 0.01 * max_speed_rad_s,
            dyn_imbalance_kgm2: 0.0,
            static_imbalance_kgm: 0.0,
            ..Self::paper001()
        }
    }

    /// Checks every field used by the selected fidelity; the error names the field.
    pub fn validate(&self) -> Result<(), String> {
        let pos = |n: &str, v: f64| {
            if v.is_finite() && v > 0.0 { Ok(()) } else { Err(format!("{n} must be finite and > 0 (got {v})")) }
        };
        let nonneg = |n: &str, v: f64| {
            if v.is_finite() && v >= 0.0 { Ok(()) } else { Err(format!("{n} must be finite and >= 0 (got {v})")) }
        };
        pos("inertia_kgm2", self.inertia_kgm2)?;
        let n = norm(&self.spin_axis);
        if !n.is_finite() || (n - 1.0).abs() >= 1e-9 {
            return Err(format!("spin_axis must be a unit vector (norm {n})"));
        }
        if !self.position_m.iter().all(|v| v.is_finite()) {
            return Err("position_m must be finite".into());
        }
        pos("max_torque_nm", self.max_torque_nm)?;
        pos("max_speed_rad_s", self.max_speed_rad_s)?;
        nonneg("torque_lag_s", self.torque_lag_s)?;
        nonneg("torque_delay_s", self.torque_delay_s)?;
        if self.fidelity == Fidelity::Ideal {
            return pos("ideal_speed_band_rad_s", self.ideal_speed_band_rad_s);
        }
        pos("max_current_a", self.max_current_a)?;
        nonneg("quiescent_power_w", self.quiescent_power_w)?;
        pos("max_power_w", self.max_power_w)?;
        if self.max_power_w <= self.quiescent_power_w {
            return Err("max_power_w must exceed quiescent_power_w".into());
        }
        nonneg("control_loss_coeff", self.control_loss_coeff)?;
        pos("torque_constant_nm_per_a", self.torque_constant_nm_per_a)?;
        pos("resistance_ohm", self.resistance_ohm)?;
        pos("motor_voltage_max_v", self.motor_voltage_max_v)?;
        if self.speed_limiter {
            pos("speed_limiter_gain_ohm", self.speed_limiter_gain_ohm)?;
        }
        nonneg("speed_loop_gain", self.speed_loop_gain)?;
        nonneg("viscous_nms", self.viscous_nms)?;
        nonneg("coulomb_nm", self.coulomb_nm)?;
        nonneg("dahl_beta", self.dahl_beta)?;
        pos("sign_smoothing_rad_s", self.sign_smoothing_rad_s)?;
        nonneg("bearing_nm", self.bearing_nm)?;
        nonneg("ripple_nm", self.ripple_nm)?;
        nonneg("motor_poles", self.motor_poles)?;
        if !self.phase_rad.is_finite() {
            return Err("phase_rad must be finite".into());
        }
        nonneg("dyn_imbalance_kgm2", self.dyn_imbalance_kgm2)?;
        nonneg("static_imbalance_kgm", self.static_imbalance_kgm)
    }

    /// Highest relative speed the model can reach (speed limiter, else back-EMF speed).
    pub fn top_speed_rad_s(&self) -> f64 {
        if self.fidelity == Fidelity::Ideal || self.speed_limiter {
            self.max_speed_rad_s
        } else {
            self.motor_voltage_max_v / self.torque_constant_nm_per_a
        }
    }

    /// Largest eigenvalue magnitude (1/s) of the wheel's own dynamics, worst case over the envelope.
    pub fn fastest_rate_per_s(&self) -> f64 {
        let iw = self.inertia_kgm2;
        let r = match self.fidelity {
            Fidelity::Ideal => self.max_torque_nm / (iw * self.ideal_speed_band_rad_s),
            Fidelity::Accurate => {
                let k = self.torque_constant_nm_per_a;
                let lim = if self.speed_limiter { k * k / (self.speed_limiter_gain_ohm * iw) } else { 0.0 };
                [
                    k * self.speed_loop_gain / iw,
                    k * k / (self.resistance_ohm * iw),
                    self.viscous_nms / iw,
                    4.0 * self.dahl_beta * self.coulomb_nm * self.top_speed_rad_s(),
                    lim,
                ]
                .into_iter()
                .fold(0.0, f64::max)
            }
        };
        // The command lag's pole (only when there is one: same bits without it).
        let r = if self.torque_lag_s > 0.0 { r.max(1.0 / self.torque_lag_s) } else { r };
        r.max(1e-12)
    }

    /// `1 / fastest_rate_per_s`.
    pub fn fastest_time_constant_s(&self) -> f64 {
        1.0 / self.fastest_rate_per_s()
    }

    /// Largest RK4 step that keeps the wheel dynamics stable (2.5 / rate; RK4 limit is 2.785).
    pub fn max_stable_step_s(&self) -> f64 {
        2.5 / self.fastest_rate_per_s()
    }

    /// Step resolving the highest periodic disturbance at top speed with 8 samples per period
    /// (accuracy of the bearing / ripple / imbalance terms, not stability).
    pub fn harmonic_step_s(&self) -> f64 {
        let n = if self.fidelity == Fidelity::Accurate && self.ripple_nm > 0.0 {
            (3.0 * self.motor_poles).max(1.0)
        } else {
            1.0
        };
        2.0 * std::f64::consts::PI / (8.0 * n * self.top_speed_rad_s())
    }

    /// Unit vectors `â1, â2` spanning the plane normal to the spin axis (`â1 × â2 = a`).
    pub fn transverse_basis(&self) -> ([f64; 3], [f64; 3]) {
        let a = &self.spin_axis;
        let i = (0..3).min_by(|&i, &j| a[i].abs().total_cmp(&a[j].abs())).unwrap();
        let mut e = [0.0; 3];
        e[i] = 1.0;
        let u = cross(&e, a);
        let n = norm(&u);
        let u1 = [u[0] / n, u[1] / n, u[2] / n];
        (u1, cross(a, &u1))
    }
}

impl WheelState {
    /// State with relative speed `speed_rad_s`, loop error zero, Dahl friction converged.
    pub fn spinning(p: &WheelParams, speed_rad_s: f64, body_rate_rad_s: &[f64; 3]) -> Self {
        let tf = if p.fidelity == Fidelity::Accurate {
            p.coulomb_nm * (speed_rad_s / p.sign_smoothing_rad_s).tanh()
        } else {
            0.0
        };
        WheelState {
            h_abs_nms: p.inertia_kgm2 * (speed_rad_s + dot(&p.spin_axis, body_rate_rad_s)),
            rotor_angle_rad: 0.0,
            dahl_friction_nm: tf,
            speed_ref_rad_s: speed_rad_s,
            applied_torque_nm: 0.0,
        }
    }

    /// `self + dt * d` (for the simulator's RK4).
    pub fn add_scaled(&self, d: &WheelDeriv, dt: f64) -> Self {
        WheelState {
            h_abs_nms: self.h_abs_nms + dt * d.dh_abs_nm,
            rotor_angle_rad: self.rotor_angle_rad + dt * d.drotor_angle,
            dahl_friction_nm: self.dahl_friction_nm + dt * d.ddahl,
            speed_ref_rad_s: self.speed_ref_rad_s + dt * d.dspeed_ref,
            applied_torque_nm: self.applied_torque_nm + dt * d.dapplied_torque,
        }
    }
}

/// The command the model sees and the lag state's derivative: with `torque_lag_s > 0` the lag
/// state `T_a` and `(T_cmd - T_a)/τ_a` (module doc), else the command itself and 0.
fn lagged_command(p: &WheelParams, s: &WheelState, torque_cmd_nm: f64) -> (f64, f64) {
    if p.torque_lag_s > 0.0 {
        (s.applied_torque_nm, (torque_cmd_nm - s.applied_torque_nm) / p.torque_lag_s)
    } else {
        (torque_cmd_nm, 0.0)
    }
}

/// Ideal model: the command clipped to ±`max_torque_nm`, faded near the speed limit.
fn ideal_torque(p: &WheelParams, torque_cmd_nm: f64, w: f64, sgn: f64) -> f64 {
    let tmax = p.max_torque_nm;
    let mut t = torque_cmd_nm.clamp(-tmax, tmax);
    // no torque pushing past ω_max: accelerating torque fades to 0 at ω_max (brakes above)
    let lim = (tmax * (p.max_speed_rad_s - w.abs()) / p.ideal_speed_band_rad_s).max(-tmax);
    if sgn * t > lim {
        t = sgn * lim;
    }
    t
}

/// A seized wheel (`[[faults]]` kind "stuck", issue 42): no axial torque between rotor and
/// body, so `ḣ_a = 0` (absolute momentum frozen) while the rotor angle still follows the
/// relative speed; friction, speed loop and lag states hold. The imbalance of the still
/// spinning rotor stays; the motor draws nothing.
pub fn seized((d, o): (WheelDeriv, WheelOutput)) -> (WheelDeriv, WheelOutput) {
    let d = WheelDeriv { drotor_angle: d.drotor_angle, ..WheelDeriv::default() };
    let o = WheelOutput {
        speed_rad_s: o.speed_rad_s,
        speed_error_rad_s: o.speed_error_rad_s,
        imbalance_force_n: o.imbalance_force_n,
        imbalance_torque_nm: o.imbalance_torque_nm,
        ..WheelOutput::default()
    };
    (d, o)
}

/// Everything at one instant. `torque_cmd_nm`: commanded axial torque from the flight code (the
/// T_cmd of eq 26: the wheel's share of the control torque, sign = torque on the wheel rotor, i.e.
/// the body gets -torque). `body_rate`: ω in body axes. `body_accel` only feeds the
/// `speed_accel_rad_s2` output (eq 23); the derivatives do not depend on it.
pub fn evaluate(
    p: &WheelParams,
    s: &WheelState,
    torque_cmd_nm: f64,
    body_rate_rad_s: &[f64; 3],
    body_accel_rad_s2: &[f64; 3],
) -> (WheelDeriv, WheelOutput) {
    let iw = p.inertia_kgm2;
    let w = s.h_abs_nms / iw - dot(&p.spin_axis, body_rate_rad_s); // eq 4 solved for ω_w
    let mut o = WheelOutput { speed_rad_s: w, ..Default::default() };
    let (torque_cmd_nm, dapplied_torque) = lagged_command(p, s, torque_cmd_nm);
    let mut d = WheelDeriv { drotor_angle: w, dapplied_torque, ..Default::default() };
    let sgn = if w >= 0.0 { 1.0 } else { -1.0 };
    match p.fidelity {
        Fidelity::Ideal => {
            let t = ideal_torque(p, torque_cmd_nm, w, sgn);
            d.dh_abs_nm = t;
            d.dspeed_ref = t / iw;
            o.motor_torque_nm = t;
            o.power_w = w * t;
        }
        Fidelity::Accurate => {
            let k = p.torque_constant_nm_per_a;
            let r = p.resistance_ohm;
            let vm = p.motor_voltage_max_v;
            // eq 25 (G = -K_c, fig 5 speed loop, eq 10)
            let e = w - s.speed_ref_rad_s;
            let mut i = torque_cmd_nm / k - p.speed_loop_gain * e;
            // eq 27 speed limiter, accelerating direction only
            if p.speed_limiter {
                let l = k * (p.max_speed_rad_s - w.abs()) / p.speed_limiter_gain_ohm;
                i = if w >= 0.0 { i.min(l) } else { i.max(-l) };
            }
            // eqs 28-29 supply voltage: |R I + K_f ω_w| <= V_max_m
            i = i.max((-vm - k * w) / r).min((vm - k * w) / r);
            // current, torque and eq 30 power limits (interval always contains 0: hard limits)
            let imax = p.max_current_a.min(p.max_torque_nm / k);
            let c = p.max_power_w - p.quiescent_power_w;
            let b = p.control_loss_coeff * vm;
            let hi = imax.min(quad_root(r, b + k * w, c));
            let lo = -imax.min(quad_root(r, b - k * w, c));
            i = i.max(lo).min(hi);
            // eqs 14, 15, 21, 22
            let phi = s.rotor_angle_rad + p.phase_rad;
            let tv = p.viscous_nms * w;
            let tf = s.dahl_friction_nm;
            let dist = p.bearing_nm * phi.sin() + p.ripple_nm * (3.0 * p.motor_poles * s.rotor_angle_rad).sin();
            let te = tf + tv + dist;
            // eq 23 Dahl (sign-preserving square, tanh sign)
            let x = p.coulomb_nm - tf * (w / p.sign_smoothing_rad_s).tanh();
            d.ddahl = p.dahl_beta * w * x * x.abs();
            let tm = k * i;
            d.dh_abs_nm = tm - te; // eq 24: ḣ_a = u_out
            d.dspeed_ref = (tm + k * p.speed_loop_gain * e) / iw; // = T_cmd/I_w unless limited
            // eqs 16-20 imbalance, rotating with φ in the plane normal to the spin axis
            let (a1, a2) = p.transverse_basis();
            let (sn, cs) = phi.sin_cos();
            let dir = [cs * a1[0] + sn * a2[0], cs * a1[1] + sn * a2[1], cs * a1[2] + sn * a2[2]];
            let (fd, fs) = (p.dyn_imbalance_kgm2 * w * w, p.static_imbalance_kgm * w * w);
            o.imbalance_force_n = dir.map(|v| fs * v);
            let us = cross(&p.position_m, &o.imbalance_force_n);
            o.imbalance_torque_nm = [fd * dir[0] + us[0], fd * dir[1] + us[1], fd * dir[2] + us[2]];
            o.current_a = i;
            o.voltage_v = r * i + k * w;
            o.power_w = p.quiescent_power_w + r * i * i + b * i.abs() + k * w * i;
            o.motor_torque_nm = tm;
            o.friction_nm = tf + tv;
            o.disturbance_nm = dist;
            o.speed_error_rad_s = e;
        }
    }
    o.delivered_torque_nm = -d.dh_abs_nm;
    o.speed_accel_rad_s2 = d.dh_abs_nm / iw - dot(&p.spin_axis, body_accel_rad_s2); // eq 23
    (d, o)
}
