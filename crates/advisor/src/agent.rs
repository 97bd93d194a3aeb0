//! One actor-critic agent (spec §5, §6.1, §6.4): the basal rate has one, each
//! carb ratio has one.
//!
//! Variant A (default, seed eq4-7 and 28): a discounted linear V-critic with
//! TD(λ); the actor step of decision k is taken at decision k+1, when its
//! outcome (the next window) is known, just before the new action.
//! Variant B (ablation, Konda & Tsitsiklis 2003 as summarised in spec §5.2):
//! an average-cost Q-critic on φ = (ψ; g) with compatible features
//! ψ = (P_e − P_d)/σ²·h·F.

use crate::config::{
    AbbaConfig, ActorRule, CostTiming, CriticBasis, CriticVariant, GradientAction,
};
use crate::features::Features;
use crate::fusion::Applied;
use crate::rng::ExplorationRng;
use crate::supervisor::ParamKind;
use serde::{Deserialize, Serialize};

/// What the learning step did before a decision.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
pub struct Learning {
    /// TD error d_k (None at an agent's first decision).
    pub td_error: Option<f64>,
    /// Critic step size a_k used (None if no critic step).
    pub critic_step_size: Option<f64>,
    /// The actor step.
    pub actor: ActorStep,
    /// θ before the step (hyper, hypo).
    pub theta_before: [f64; 2],
    /// θ after the step (hyper, hypo).
    pub theta_after: [f64; 2],
}

/// Outcome of the policy update (eq28 in Variant A).
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
#[serde(rename_all = "snake_case", tag = "kind")]
pub enum ActorStep {
    /// First decision of this agent: nothing to learn from yet.
    NoPreviousDecision,
    /// Skipped: σ below `actor.sigma_min` (includes F = 0), the safeguard of spec §6.4.
    SkippedSmallSigma {
        /// The σ of the decision being credited.
        sigma: f64,
    },
    /// Skipped: the TD error was not finite (never expected with bounded features).
    SkippedNonFinite,
    /// Applied Δθ (after clipping and, under the projected actor, projection).
    Applied {
        /// Δθ (hyper, hypo), after clipping and projection.
        delta: [f64; 2],
        /// Whether the |Δθ_j| ≤ clip safeguard or the sign projection fired.
        clipped: bool,
    },
}

/// The sampled action of a decision (eq22-25).
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
pub struct Action {
    /// P_a = F·θ (eq25).
    pub p_a: f64,
    /// P_s, the supervisory action.
    pub p_s: f64,
    /// P_d = h·P_a + (1−h)·P_s (eq24).
    pub p_d: f64,
    /// σ = c_σ·‖F‖² (eq22).
    pub sigma: f64,
    /// The standard-normal draw z of the exploration generator.
    pub z: f64,
    /// The exploration term σ·z.
    pub exploration: f64,
    /// P_e = P_d + σ·z (eq23).
    pub p_e: f64,
}

/// The critic's parameters.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(rename_all = "snake_case", tag = "variant")]
pub(crate) enum Critic {
    /// Variant A.
    ValueTd {
        w: [f64; 3],
        z: [f64; 3],
        steps: u32,
    },
    /// Variant B.
    KondaTsitsiklis {
        r: [f64; 5],
        z: [f64; 5],
        avg_cost: f64,
        steps: u32,
    },
}

/// What is remembered of the previous decision for its learning step.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
pub(crate) struct LastDecision {
    f: [f64; 2],
    g: [f64; 3],
    phi: [f64; 5],
    cost: f64,
    p_e: f64,
    p_d: f64,
    sigma: f64,
}

/// Counters of the actor safeguards (spec §6.4 asks to report how often the clip fires).
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq, Serialize, Deserialize)]
pub struct AgentCounters {
    /// Decisions made.
    pub decisions: u32,
    /// Actor steps applied.
    pub actor_steps: u32,
    /// Actor steps whose Δθ was clipped.
    pub actor_clips: u32,
    /// Actor steps skipped (small σ or non-finite TD error).
    pub actor_skips: u32,
}

/// One agent: policy θ, critic, last decision, exploration generator.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub(crate) struct Agent {
    pub(crate) kind: ParamKind,
    pub(crate) theta: [f64; 2],
    critic: Critic,
    last: Option<LastDecision>,
    pub(crate) counters: AgentCounters,
    rng: ExplorationRng,
}

fn dot<const N: usize>(a: &[f64; N], b: &[f64; N]) -> f64 {
    a.iter().zip(b).map(|(x, y)| x * y).sum()
}

/// The clinical sign pattern of θ = (θ_hyper, θ_hypo) for a parameter kind:
/// for the basal rate (+, −), for a carb ratio (−, +). A projection onto it
/// sets a component of the wrong sign to 0.
pub(crate) fn project_sign_pattern(kind: ParamKind, theta: [f64; 2]) -> [f64; 2] {
    match kind {
        ParamKind::Basal => [theta[0].max(0.0), theta[1].min(0.0)],
        ParamKind::CarbRatio => [theta[0].min(0.0), theta[1].max(0.0)],
    }
}

/// True when θ is in the clinical sign pattern of `kind` (zeros allowed).
pub fn in_sign_pattern(kind: ParamKind, theta: [f64; 2]) -> bool {
    project_sign_pattern(kind, theta) == theta
}

fn clip_step(delta: [f64; 2], clip: f64) -> ([f64; 2], bool) {
    let c = [delta[0].clamp(-clip, clip), delta[1].clamp(-clip, clip)];
    (c, c != delta)
}

impl Agent {
    /// A fresh agent with θ = 0 (θ is set by the TE initialisation).
    pub(crate) fn new(kind: ParamKind, variant: CriticVariant, seed: u64, stream: u64) -> Self {
        let critic = match variant {
            CriticVariant::ValueTd => Critic::ValueTd {
                w: [0.0; 3],
                z: [0.0; 3],
                steps: 0,
            },
            CriticVariant::KondaTsitsiklis => Critic::KondaTsitsiklis {
                r: [0.0; 5],
                z: [0.0; 5],
                avg_cost: 0.0,
                steps: 0,
            },
        };
        Self {
            kind,
            theta: [0.0; 2],
            critic,
            last: None,
            counters: AgentCounters::default(),
            rng: ExplorationRng::new(seed, stream),
        }
    }

    /// Critic weights (w for Variant A, r for Variant B), for inspection.
    pub(crate) fn critic_weights(&self) -> Vec<f64> {
        match &self.critic {
            Critic::ValueTd { w, .. } => w.to_vec(),
            Critic::KondaTsitsiklis { r, .. } => r.to_vec(),
        }
    }

    fn basis(f: &Features, cfg: &AbbaConfig) -> [f64; 3] {
        let bias = match cfg.critic.basis {
            CriticBasis::WithBias => 1.0,
            CriticBasis::FeaturesOnly => 0.0,
        };
        [bias, f.hyper, f.hypo]
    }

    fn step_size(steps: u32, cfg: &AbbaConfig) -> f64 {
        cfg.critic.a0 / (1.0 + f64::from(steps) / cfg.critic.kappa)
    }

    fn sample(&mut self, f: &Features, p_s: f64, cfg: &AbbaConfig) -> Action {
        let p_a = dot(&f.vector(), &self.theta); // eq25
        let h = cfg.actor.h;
        let p_d = h * p_a + (1.0 - h) * p_s; // eq24
        let sigma = cfg.actor.c_sigma * f.norm_sq(); // eq22
        let z = self.rng.standard_normal(); // drawn every time: fixed consumption per decision
        let exploration = sigma * z;
        Action {
            p_a,
            p_s,
            p_d,
            sigma,
            z,
            exploration,
            p_e: p_d + exploration, // eq23
        }
    }

    fn gradient_action(action: &Action, applied: &Applied, cfg: &AbbaConfig) -> f64 {
        match cfg.actor.gradient_action {
            GradientAction::Sampled => action.p_e,
            GradientAction::Effective => {
                (applied.new / applied.old - 1.0) / (1.0 - cfg.update.fusion_m)
            }
        }
    }

    /// One decision: learning step for the previous decision, then a new
    /// action, applied through `apply` (fusion, switch rule, clamp), by the
    /// configured critic.
    pub(crate) fn decide(
        &mut self,
        f: &Features,
        cost: f64,
        p_s: f64,
        cfg: &AbbaConfig,
        apply: impl FnOnce(f64) -> Applied,
    ) -> (Learning, Action, Applied) {
        let (learning, action, applied, last) = match self.critic.clone() {
            Critic::ValueTd { w, z, steps } => {
                self.decide_value_td(f, cost, p_s, cfg, apply, (w, z, steps))
            }
            Critic::KondaTsitsiklis {
                r,
                z,
                avg_cost,
                steps,
            } => self.decide_konda_tsitsiklis(f, cost, p_s, cfg, apply, (r, z, avg_cost, steps)),
        };
        self.last = Some(last);
        self.counters.decisions += 1;
        (learning, action, applied)
    }

    /// A decision with the value-function TD(λ) critic (eq5-eq7): the
    /// previous decision's TD error updates the critic, then the actor
    /// (eq28 or the projected natural step); then the new action.
    fn decide_value_td(
        &mut self,
        f: &Features,
        cost: f64,
        p_s: f64,
        cfg: &AbbaConfig,
        apply: impl FnOnce(f64) -> Applied,
        (mut w, mut z, mut steps): ([f64; 3], [f64; 3], u32),
    ) -> (Learning, Action, Applied, LastDecision) {
        let theta_before = self.theta;
        let g = Self::basis(f, cfg);
        let mut td_error = None;
        let mut critic_step_size = None;
        let mut actor = ActorStep::NoPreviousDecision;
        if let Some(prev) = self.last {
            let c = match cfg.critic.cost_timing {
                CostTiming::Outcome => cost,
                CostTiming::Literal => prev.cost,
            };
            // eq5 with the outcome convention of spec §5.1.
            let d = c + cfg.critic.gamma * dot(&w, &g) - dot(&w, &prev.g);
            td_error = Some(d);
            if d.is_finite() {
                let a_k = Self::step_size(steps, cfg);
                critic_step_size = Some(a_k);
                for j in 0..3 {
                    w[j] += a_k * d * z[j]; // eq6
                    z[j] = cfg.critic.lambda * z[j] + g[j]; // eq7
                }
                steps += 1;
                actor = match cfg.actor.rule {
                    ActorRule::Eq28 => self.actor_step_eq28(&prev, d, cfg),
                    ActorRule::ProjectedNatural => self.actor_step_natural(&prev, d, cfg),
                };
            } else {
                actor = ActorStep::SkippedNonFinite;
                self.counters.actor_skips += 1;
            }
        } else {
            z = g; // z_0 = g(x_0)
        }
        let action = self.sample(f, p_s, cfg);
        let applied = apply(action.p_e);
        let last = LastDecision {
            f: f.vector(),
            g,
            phi: [0.0, 0.0, g[0], g[1], g[2]],
            cost,
            p_e: Self::gradient_action(&action, &applied, cfg),
            p_d: action.p_d,
            sigma: action.sigma,
        };
        self.critic = Critic::ValueTd { w, z, steps };
        let learning = Learning {
            td_error,
            critic_step_size,
            actor,
            theta_before,
            theta_after: self.theta,
        };
        (learning, action, applied, last)
    }

    /// A decision with Konda and Tsitsiklis's actor-critic: the new action
    /// from the current θ, then the critic's average-cost TD update on the
    /// compatible features and the actor's step (affecting the next action).
    fn decide_konda_tsitsiklis(
        &mut self,
        f: &Features,
        cost: f64,
        p_s: f64,
        cfg: &AbbaConfig,
        apply: impl FnOnce(f64) -> Applied,
        (mut r, mut z, mut avg_cost, mut steps): ([f64; 5], [f64; 5], f64, u32),
    ) -> (Learning, Action, Applied, LastDecision) {
        let theta_before = self.theta;
        let g = Self::basis(f, cfg);
        let h = cfg.actor.h;
        // The new action comes from the current θ; the update affects the next one.
        let action = self.sample(f, p_s, cfg);
        let applied = apply(action.p_e);
        let p_e = Self::gradient_action(&action, &applied, cfg);
        let psi = if action.sigma >= cfg.actor.sigma_min {
            let k = (p_e - action.p_d) / (action.sigma * action.sigma) * h;
            [k * f.hyper, k * f.hypo]
        } else {
            [0.0, 0.0]
        };
        let phi = [psi[0], psi[1], g[0], g[1], g[2]];
        let mut td_error = None;
        let mut critic_step_size = None;
        let mut actor = ActorStep::NoPreviousDecision;
        if let Some(prev) = self.last {
            let c = match cfg.critic.cost_timing {
                CostTiming::Outcome => cost,
                CostTiming::Literal => prev.cost,
            };
            let d = c - avg_cost + dot(&r, &phi) - dot(&r, &prev.phi);
            td_error = Some(d);
            if d.is_finite() {
                let a_k = Self::step_size(steps, cfg);
                critic_step_size = Some(a_k);
                for j in 0..5 {
                    r[j] += a_k * d * z[j];
                    z[j] = cfg.critic.lambda * z[j] + phi[j];
                }
                avg_cost += a_k * (c - avg_cost);
                steps += 1;
                if action.sigma < cfg.actor.sigma_min {
                    self.counters.actor_skips += 1;
                    actor = ActorStep::SkippedSmallSigma {
                        sigma: action.sigma,
                    };
                } else {
                    let q = dot(&r, &phi);
                    let raw = [-cfg.actor.beta * q * psi[0], -cfg.actor.beta * q * psi[1]];
                    actor = self.apply_theta_step(raw, cfg);
                }
            } else {
                actor = ActorStep::SkippedNonFinite;
                self.counters.actor_skips += 1;
            }
        } else {
            z = phi;
        }
        let last = LastDecision {
            f: f.vector(),
            g,
            phi,
            cost,
            p_e,
            p_d: action.p_d,
            sigma: action.sigma,
        };
        self.critic = Critic::KondaTsitsiklis {
            r,
            z,
            avg_cost,
            steps,
        };
        let learning = Learning {
            td_error,
            critic_step_size,
            actor,
            theta_before,
            theta_after: self.theta,
        };
        (learning, action, applied, last)
    }

    /// eq28 for the stored decision `prev` with TD error `d`, with the safeguards of spec §6.4.
    fn actor_step_eq28(&mut self, prev: &LastDecision, d: f64, cfg: &AbbaConfig) -> ActorStep {
        if prev.sigma < cfg.actor.sigma_min {
            self.counters.actor_skips += 1;
            return ActorStep::SkippedSmallSigma { sigma: prev.sigma };
        }
        // ∇θ P_d = h·F_k; ψ = (P_e − P_d)/σ²·h·F_k.
        let k = (prev.p_e - prev.p_d) / (prev.sigma * prev.sigma) * cfg.actor.h;
        let raw = [
            -cfg.actor.beta * d * k * prev.f[0],
            -cfg.actor.beta * d * k * prev.f[1],
        ];
        self.apply_theta_step(raw, cfg)
    }

    /// The projected natural-gradient step (the default `actor.rule`) for the
    /// stored decision `prev` with TD error `d`.
    fn actor_step_natural(&mut self, prev: &LastDecision, d: f64, cfg: &AbbaConfig) -> ActorStep {
        let norm_sq = prev.f[0] * prev.f[0] + prev.f[1] * prev.f[1];
        // F = 0 (or no exploration at all): the step is 0/0; nothing to learn.
        if norm_sq < 1e-12 || prev.sigma <= 0.0 || cfg.actor.h <= 0.0 {
            self.counters.actor_skips += 1;
            return ActorStep::SkippedSmallSigma { sigma: prev.sigma };
        }
        let k = f64::from(self.counters.actor_steps);
        let decay = 1.0 + k / cfg.critic.kappa;
        let beta = cfg.actor.natural_beta / (decay * decay);
        let scale = -beta * d * (prev.p_e - prev.p_d) / (cfg.actor.h * norm_sq);
        self.apply_theta_step([scale * prev.f[0], scale * prev.f[1]], cfg)
    }

    fn apply_theta_step(&mut self, raw: [f64; 2], cfg: &AbbaConfig) -> ActorStep {
        if !(raw[0].is_finite() && raw[1].is_finite()) {
            self.counters.actor_skips += 1;
            return ActorStep::SkippedNonFinite;
        }
        let (mut delta, mut clipped) = clip_step(raw, cfg.actor.theta_step_clip);
        if cfg.actor.rule == ActorRule::ProjectedNatural {
            let before = self.theta;
            let moved = [before[0] + delta[0], before[1] + delta[1]];
            let projected = project_sign_pattern(self.kind, moved);
            if projected != moved {
                clipped = true;
            }
            delta = [projected[0] - before[0], projected[1] - before[1]];
            self.theta = projected;
            self.counters.actor_steps += 1;
            if clipped {
                self.counters.actor_clips += 1;
            }
            return ActorStep::Applied { delta, clipped };
        }
        self.theta[0] += delta[0];
        self.theta[1] += delta[1];
        self.counters.actor_steps += 1;
        if clipped {
            self.counters.actor_clips += 1;
        }
        ActorStep::Applied { delta, clipped }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::config::Mode;
    use crate::fusion::apply_action;

    fn feats(hyper: f64, hypo: f64) -> Features {
        Features {
            hyper,
            hypo,
            ..Default::default()
        }
    }

    fn close(name: &str, expected: f64, got: f64) {
        assert!(
            (expected - got).abs() < 1e-12,
            "{name}: expected {expected}, got {got}"
        );
    }

    fn apply_basal(p: f64) -> Applied {
        apply_action(ParamKind::Basal, 1.0, p, 0.5, None, true, 0.05)
    }

    #[test]
    fn eq22_to_eq25_action_composition() {
        let cfg = AbbaConfig::new(Mode::Cgm, 3);
        let mut a = Agent::new(ParamKind::Basal, CriticVariant::ValueTd, 3, 0);
        a.theta = [0.1, -0.2];
        let f = feats(0.4, 0.2);
        let (_, act, applied) = a.decide(&f, 2.4, -0.01, &cfg, apply_basal);
        // P_a = 0.4*0.1 + 0.2*(-0.2) = 0.0 ; P_d = 0.5*0 + 0.5*(-0.01) = -0.005
        close("eq25 P_a", 0.0, act.p_a);
        close("eq24 P_d", -0.005, act.p_d);
        // σ = 0.05*(0.16+0.04) = 0.01
        close("eq22 sigma", 0.01, act.sigma);
        close("eq23 P_e", -0.005 + 0.01 * act.z, act.p_e);
        close("exploration", 0.01 * act.z, act.exploration);
        close("applied", 1.0 + 0.5 * act.p_e, applied.ap_fusion);
        // Sign convention of θ0 (fresh agents, so no learning step moves θ first):
        // BR (+0.1, −0.2): more hyper -> more basal, hypo -> less basal.
        let fresh = |kind, theta| {
            let mut a = Agent::new(kind, CriticVariant::ValueTd, 3, 0);
            a.theta = theta;
            a
        };
        let (_, act, _) = fresh(ParamKind::Basal, [0.1, -0.2]).decide(
            &feats(0.5, 0.0),
            0.5,
            0.0,
            &cfg,
            apply_basal,
        );
        close("hyper pushes BR up", 0.05, act.p_a);
        let (_, act, _) = fresh(ParamKind::Basal, [0.1, -0.2]).decide(
            &feats(0.0, 0.5),
            5.0,
            0.0,
            &cfg,
            apply_basal,
        );
        close("hypo pushes BR down", -0.1, act.p_a);
        // CIR (−0.1, +0.2): hyper -> smaller ratio (more bolus), hypo -> larger ratio.
        let apply_cir = |p| apply_action(ParamKind::CarbRatio, 10.0, p, 0.5, None, true, 0.05);
        let (_, act, _) = fresh(ParamKind::CarbRatio, [-0.1, 0.2]).decide(
            &feats(0.5, 0.0),
            0.5,
            0.0,
            &cfg,
            apply_cir,
        );
        close("hyper pushes CIR down", -0.05, act.p_a);
        let (_, act, _) = fresh(ParamKind::CarbRatio, [-0.1, 0.2]).decide(
            &feats(0.0, 0.5),
            5.0,
            0.0,
            &cfg,
            apply_cir,
        );
        close("hypo pushes CIR up", 0.1, act.p_a);
    }

    #[test]
    fn eq5_to_eq7_and_eq28_hand_computed() {
        let mut cfg = AbbaConfig::new(Mode::Cgm, 11);
        cfg.actor.rule = ActorRule::Eq28;
        let mut a = Agent::new(ParamKind::Basal, CriticVariant::ValueTd, 11, 0);
        a.theta = [0.1, -0.2];
        // Decision 0 at F0 = (0.4, 0): z0 = g0 = (1, 0.4, 0); w0 = 0.
        let (l0, act0, _) = a.decide(&feats(0.4, 0.0), 0.4, 0.0, &cfg, apply_basal);
        assert_eq!(l0.td_error, None);
        assert_eq!(l0.actor, ActorStep::NoPreviousDecision);
        // Decision 1 at F1 = (0.2, 0): cost c1 = 0.2.
        // d = c1 + γ w·g1 − w·g0 = 0.2 (w = 0).
        let (l1, _, _) = a.decide(&feats(0.2, 0.0), 0.2, 0.0, &cfg, apply_basal);
        close("eq5 d", 0.2, l1.td_error.unwrap());
        close("a_0", 0.1, l1.critic_step_size.unwrap());
        // eq6: w = 0 + 0.1*0.2*(1, 0.4, 0) = (0.02, 0.008, 0)
        let w = a.critic_weights();
        close("eq6 w0", 0.02, w[0]);
        close("eq6 w1", 0.008, w[1]);
        close("eq6 w2", 0.0, w[2]);
        // eq7: z = 0.5*(1, 0.4, 0) + (1, 0.2, 0) = (1.5, 0.4, 0)
        if let Critic::ValueTd { z, steps, .. } = &a.critic {
            close("eq7 z0", 1.5, z[0]);
            close("eq7 z1", 0.4, z[1]);
            assert_eq!(*steps, 1);
        } else {
            panic!("variant A expected");
        }
        // eq28 on decision 0: σ0 = 0.05*0.16 = 0.008; P_d0 = 0.5*0.04 = 0.02; ε0 = σ0 z0.
        // Δθ = −β d (P_e − P_d)/σ² h F0 = −0.5*0.2*(ε0/σ0²)*0.5*(0.4, 0)
        let eps0 = act0.p_e - act0.p_d;
        let expected = -0.5 * 0.2 * eps0 / (0.008 * 0.008) * 0.5 * 0.4;
        let clip = cfg.actor.theta_step_clip;
        let expected_clipped = expected.clamp(-clip, clip);
        match l1.actor {
            ActorStep::Applied { delta, clipped } => {
                close("eq28 Δθ_hyper", expected_clipped, delta[0]);
                close("eq28 Δθ_hypo", 0.0, delta[1]);
                assert_eq!(clipped, expected.abs() > clip);
            }
            other => panic!("expected an actor step, got {other:?}"),
        }
        close("θ after", 0.1 + expected_clipped, l1.theta_after[0]);
    }

    #[test]
    fn eq28_direction_lowers_cost() {
        // A positive TD error (worse than expected) after an exploratory push
        // up must move θ against that push; a negative one along it. The
        // spec-literal clip of 0.5 keeps the raw eq28 step visible.
        let mut cfg = AbbaConfig::new(Mode::Cgm, 5);
        cfg.actor.rule = ActorRule::Eq28;
        cfg.actor.theta_step_clip = 0.5;
        let prev = LastDecision {
            f: [0.2, 0.0],
            g: [1.0, 0.2, 0.0],
            phi: [0.0; 5],
            cost: 0.2,
            p_e: 0.0021, // P_e − P_d = +0.0001
            p_d: 0.002,
            sigma: 0.002,
        };
        let mut a = Agent::new(ParamKind::Basal, CriticVariant::ValueTd, 5, 0);
        // Δθ_hyper = −0.5*0.1*(0.0001/0.000004)*0.5*0.2 = −0.125
        match a.actor_step_eq28(&prev, 0.1, &cfg) {
            ActorStep::Applied { delta, clipped } => {
                close("Δθ for d>0", -0.125, delta[0]);
                assert!(!clipped);
            }
            other => panic!("{other:?}"),
        }
        match a.actor_step_eq28(&prev, -0.1, &cfg) {
            ActorStep::Applied { delta, .. } => close("Δθ for d<0", 0.125, delta[0]),
            other => panic!("{other:?}"),
        }
        // Safeguards: a huge step is clipped to 0.5; σ < 1e-4 skips.
        match a.actor_step_eq28(&prev, 10.0, &cfg) {
            ActorStep::Applied { delta, clipped } => {
                close("clipped", -0.5, delta[0]);
                assert!(clipped);
            }
            other => panic!("{other:?}"),
        }
        let tiny = LastDecision {
            sigma: 5e-5,
            ..prev
        };
        assert_eq!(
            a.actor_step_eq28(&tiny, 1.0, &cfg),
            ActorStep::SkippedSmallSigma { sigma: 5e-5 }
        );
        assert_eq!(a.counters.actor_clips, 1);
        assert_eq!(a.counters.actor_skips, 1);
    }

    #[test]
    fn natural_step_hand_computed_and_decaying() {
        let mut cfg = AbbaConfig::new(Mode::Cgm, 5);
        cfg.actor.natural_beta = 0.2;
        cfg.actor.theta_step_clip = 1.0;
        let prev = LastDecision {
            f: [0.2, 0.1],
            g: [1.0, 0.2, 0.1],
            phi: [0.0; 5],
            cost: 1.2,
            p_e: 0.003,
            p_d: 0.001,
            sigma: 0.0025,
        };
        let mut a = Agent::new(ParamKind::Basal, CriticVariant::ValueTd, 5, 0);
        a.theta = [0.1, -0.2];
        // Δθ = −β·d·(P_e − P_d)·F/(h‖F‖²) = −0.2·(−0.5)·0.002/(0.5·0.05)·F = 0.008·F
        match a.actor_step_natural(&prev, -0.5, &cfg) {
            ActorStep::Applied { delta, clipped } => {
                close("Δθ_hyper", 0.008 * 0.2, delta[0]);
                close("Δθ_hypo", 0.008 * 0.1, delta[1]);
                assert!(!clipped);
            }
            other => panic!("{other:?}"),
        }
        // Second step: β_1 = 0.2/(1 + 1/30)², slower than the critic's a_k.
        let before = a.theta;
        a.actor_step_natural(&prev, -0.5, &cfg);
        let decay = (1.0 + 1.0 / 30.0) * (1.0f64 + 1.0 / 30.0);
        close("decayed step", 0.008 * 0.2 / decay, a.theta[0] - before[0]);
        // F = 0: skipped, θ unchanged.
        let zero = LastDecision {
            f: [0.0, 0.0],
            sigma: 0.0,
            ..prev
        };
        let t = a.theta;
        assert!(matches!(
            a.actor_step_natural(&zero, 1.0, &cfg),
            ActorStep::SkippedSmallSigma { .. }
        ));
        assert_eq!(a.theta, t);
    }

    #[test]
    fn projection_keeps_the_clinical_sign_pattern() {
        let mut cfg = AbbaConfig::new(Mode::Cgm, 5);
        cfg.actor.natural_beta = 50.0;
        cfg.actor.theta_step_clip = 100.0;
        let prev = LastDecision {
            f: [0.3, 0.3],
            g: [1.0, 0.3, 0.3],
            phi: [0.0; 5],
            cost: 3.3,
            p_e: 0.01,
            p_d: 0.0,
            sigma: 0.009,
        };
        // A large positive d after an upward push drives θ down along F:
        // θ_hyper of the basal agent would turn negative; projected to 0.
        let mut a = Agent::new(ParamKind::Basal, CriticVariant::ValueTd, 5, 0);
        a.theta = [0.1, -0.2];
        match a.actor_step_natural(&prev, 5.0, &cfg) {
            ActorStep::Applied { clipped, .. } => assert!(clipped),
            other => panic!("{other:?}"),
        }
        assert_eq!(a.theta[0], 0.0);
        assert!(a.theta[1] < -0.2);
        assert!(in_sign_pattern(ParamKind::Basal, a.theta));
        // The same push on a carb-ratio agent with the opposite d.
        let mut c = Agent::new(ParamKind::CarbRatio, CriticVariant::ValueTd, 5, 1);
        c.theta = [-0.1, 0.2];
        c.actor_step_natural(&prev, 5.0, &cfg);
        assert!(
            in_sign_pattern(ParamKind::CarbRatio, c.theta),
            "{:?}",
            c.theta
        );
        assert_eq!(c.theta[1], 0.0, "θ_hypo of a CIR projected to 0");
        // Eq28 has no projection: the same hostile step leaves the pattern.
        cfg.actor.rule = ActorRule::Eq28;
        let mut e = Agent::new(ParamKind::Basal, CriticVariant::ValueTd, 5, 0);
        e.theta = [0.1, -0.2];
        e.actor_step_eq28(&prev, 5.0, &cfg);
        assert!(!in_sign_pattern(ParamKind::Basal, e.theta), "{:?}", e.theta);
    }

    #[test]
    fn literal_cost_timing_uses_the_previous_cost() {
        let mut cfg = AbbaConfig::new(Mode::Cgm, 1);
        cfg.critic.cost_timing = CostTiming::Literal;
        let mut a = Agent::new(ParamKind::Basal, CriticVariant::ValueTd, 1, 0);
        a.decide(&feats(0.4, 0.0), 0.4, 0.0, &cfg, apply_basal);
        let (l, _, _) = a.decide(&feats(0.2, 0.0), 0.2, 0.0, &cfg, apply_basal);
        close("d = c(F_k) with w = 0", 0.4, l.td_error.unwrap());
    }

    #[test]
    fn variant_b_learns_average_cost_and_stays_finite() {
        let mut cfg = AbbaConfig::new(Mode::Cgm, 9);
        cfg.critic.variant = CriticVariant::KondaTsitsiklis;
        let mut a = Agent::new(ParamKind::Basal, CriticVariant::KondaTsitsiklis, 9, 0);
        a.theta = [0.1, -0.2];
        a.decide(&feats(0.3, 0.0), 0.3, 0.0, &cfg, apply_basal);
        let (l, _, _) = a.decide(&feats(0.3, 0.0), 0.3, 0.0, &cfg, apply_basal);
        // First critic step: ᾱ = 0 + 0.1*(0.3 − 0) = 0.03 and d = c − 0 + 0 − 0 = 0.3.
        close("d", 0.3, l.td_error.unwrap());
        if let Critic::KondaTsitsiklis { avg_cost, .. } = &a.critic {
            close("ᾱ", 0.03, *avg_cost);
        } else {
            panic!("variant B expected");
        }
        for k in 0..200 {
            let f = feats(0.1 + 0.001 * f64::from(k % 7), 0.0);
            a.decide(&f, f.hyper, 0.0, &cfg, apply_basal);
            assert!(a.theta.iter().all(|t| t.is_finite()));
        }
    }
}
