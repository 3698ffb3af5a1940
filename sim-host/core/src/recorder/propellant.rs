//! Propellant exceeded (issue 42; docs/scenario.md "Propellant exceeded"): with
//! `[performance] propellant_budget_kg`, a run whose thrusters used more propellant than the
//! budget (summary `propellant_kg`, the plant's `Σ F t_on / (Isp g0)`) fails (`run_status`
//! "propellant_exceeded", exit 3), never ok. A budget is a mission requirement, not a fault
//! test: it is judged with or without `[[faults]]`. A stuck-open thruster the control fights
//! within the pointing bound, or a law stiff enough to hold against it, empties the tank
//! with the pointing verdicts silent; this one sees the drain.
//!
//! Precedence: the run's other failures come first (`Simulation::outcome`), the pointing
//! verdicts (`control_lost`, `recovery_failed`, `pointing_degraded`) among them: a
//! spacecraft that lost or degraded its pointing has failed its mission whatever it burned,
//! and the status names the worse failure; the summary still carries `propellant_kg` and
//! `propellant_budget_kg` side by side, so the drain stays visible.

/// Why the run fails for its propellant, if it does: the budget is set and the propellant
/// used is above it — or not a number (`!(used <= budget)`: a NaN cannot be shown within the
/// budget). `used_kg` is `None` without thrusters (a budget is refused then, at the load).
pub fn exceeded(used_kg: Option<f64>, budget_kg: Option<f64>) -> Option<String> {
    let (used, budget) = used_kg.zip(budget_kg)?;
    (!(used <= budget)).then(|| {
        format!(
            "propellant exceeded: the thrusters used {used:.6} kg, above the budget of {budget} kg \
             ([performance] propellant_budget_kg; {:.2} times it)",
            used / budget
        )
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn exceeded_only_above_the_budget() {
        let budget = Some(0.1);
        // Just above (one ulp), at, and just below the budget.
        let above = exceeded(Some(f64::from_bits(0.1f64.to_bits() + 1)), budget);
        assert!(above.as_deref().is_some_and(|r| r.contains("budget of 0.1 kg")), "{above:?}");
        assert_eq!(exceeded(Some(0.1), budget), None);
        assert_eq!(exceeded(Some(0.099_999), budget), None);
        // The reason gives the use and the ratio to the budget.
        let r = exceeded(Some(0.25), budget).unwrap();
        assert!(r.contains("0.250000 kg") && r.contains("2.50 times"), "{r}");
        // NaN or infinite use: exceeded (cannot be shown within it).
        assert!(exceeded(Some(f64::NAN), budget).is_some());
        assert!(exceeded(Some(f64::INFINITY), budget).is_some());
        // No budget, or no thrusters: never.
        assert_eq!(exceeded(Some(1e9), None), None);
        assert_eq!(exceeded(Some(f64::NAN), None), None);
        assert_eq!(exceeded(None, budget), None);
    }
}
