//! The one [`crate::Advisor`] body of the arms that adapt (ABBA,
//! run-to-run, autotune): each event checked by the arm's
//! [`crate::guard::EventGuard`] against its configuration's limits, handed
//! to the arm, and committed to the guard only when the arm took it; the
//! settings in force, the decision log, the arm and the mode read from the
//! same fields.
//!
//! An arm opts in with `adapting::advisor!(Type, ArmKind::X)`. It must have
//! the fields `guard: EventGuard`, `config` (with `limits: EventLimits` and
//! `mode: Mode`), `settings: TherapySettings` and `log: DecisionLog`, and a
//! method `step(&mut self, &Event) -> Result<Option<TherapySettings>,
//! AdvisorError>`: the arm's handling of one checked event, which on an
//! error leaves the arm as it was.

/// `impl Advisor` for an adapting arm (see the module docs).
macro_rules! advisor {
    ($arm:ty, $kind:expr) => {
        impl $crate::Advisor for $arm {
            fn observe(
                &mut self,
                event: &abba_core::Event,
            ) -> Result<Option<abba_core::TherapySettings>, $crate::AdvisorError> {
                self.guard.check(event, &self.config.limits)?;
                let out = self.step(event)?;
                self.guard.commit(event);
                Ok(out)
            }

            fn settings(&self) -> &abba_core::TherapySettings {
                &self.settings
            }

            fn decisions(&self) -> &[$crate::Decision] {
                self.log.as_slice()
            }

            fn take_decisions(&mut self) -> Vec<$crate::Decision> {
                self.log.take()
            }

            fn arm(&self) -> $crate::ArmKind {
                $kind
            }

            fn mode(&self) -> Option<$crate::Mode> {
                Some(self.config.mode)
            }
        }
    };
}

pub(crate) use advisor;

#[cfg(test)]
mod tests {
    use crate::{
        Abba, AbbaConfig, Advisor, AdvisorError, ArmKind, Autotune, AutotuneConfig, Mode,
        R2rConfig, RunToRun,
    };
    use abba_core::{
        Event, EventKind, GramsPerUnit, MgDl, TherapySettings, Timestamp, UnitsPerHour,
    };

    fn start() -> TherapySettings {
        TherapySettings {
            basal: UnitsPerHour(1.0),
            carb_ratio: [GramsPerUnit(10.0); 3],
        }
    }

    fn cgm(at: i64, mg_dl: f64) -> Event {
        Event::new(Timestamp(at), EventKind::Cgm(MgDl(mg_dl)))
    }

    /// The shared body: arm and mode named, a good event taken, a bad one
    /// refused with the state (saved as JSON) unchanged.
    fn shared_body<A: Advisor>(
        mut a: A,
        arm: ArmKind,
        save: impl Fn(&A) -> Result<String, AdvisorError>,
    ) {
        assert_eq!(a.arm(), arm);
        assert_eq!(a.mode(), Some(Mode::Cgm));
        assert_eq!(a.observe(&cgm(10, 120.0)).unwrap(), None);
        let before = save(&a).unwrap();
        for bad in [cgm(5, 120.0), cgm(11, f64::NAN)] {
            assert!(a.observe(&bad).is_err(), "{arm:?} took {bad:?}");
            assert_eq!(save(&a).unwrap(), before, "{arm:?} changed on {bad:?}");
        }
        // The refused events were not committed: a later good one is taken.
        assert_eq!(a.observe(&cgm(11, 121.0)).unwrap(), None);
        assert_eq!(a.settings(), &start());
        assert!(a.decisions().is_empty());
        assert!(a.take_decisions().is_empty());
    }

    #[test]
    fn every_adapting_arm_has_the_one_body() {
        let abba = Abba::new(AbbaConfig::new(Mode::Cgm, 7), start()).unwrap();
        shared_body(abba, ArmKind::Abba, Abba::save_json);
        let r2r = RunToRun::new(R2rConfig::new(Mode::Cgm), start()).unwrap();
        shared_body(r2r, ArmKind::R2r, RunToRun::save_json);
        let autotune = Autotune::new(AutotuneConfig::new(Mode::Cgm), start()).unwrap();
        shared_body(autotune, ArmKind::Autotune, Autotune::save_json);
    }
}
