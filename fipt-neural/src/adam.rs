//! Adam over candle `Var`s with its state exposed, so that checkpoints resume exactly.
//!
//! (candle-nn's `AdamW` keeps its moments private and defaults to weight decay 0.01; the
//! reference trains with plain Adam.)
use crate::error::{CandleContext, NeuralError, Result};
use crate::hashgrid::AdamConfig;
use candle_core::backprop::GradStore;
use candle_core::{Tensor, Var};
use std::collections::HashMap;

/// Dense Adam over named variables.
pub struct Adam {
    cfg: AdamConfig,
    vars: Vec<(String, Var)>,
    m: Vec<Tensor>,
    v: Vec<Tensor>,
    steps: u64,
}

impl Adam {
    pub fn new(vars: Vec<(String, Var)>, cfg: AdamConfig) -> Result<Self> {
        let zeros = |v: &Var| v.as_tensor().zeros_like();
        let m = vars
            .iter()
            .map(|(_, v)| zeros(v))
            .collect::<candle_core::Result<Vec<_>>>()
            .ctx("adam")?;
        let v = m.clone();
        Ok(Adam {
            cfg,
            vars,
            m,
            v,
            steps: 0,
        })
    }

    /// Sets the learning rate of the following steps (a schedule's value at the step).
    pub fn set_lr(&mut self, lr: f32) {
        self.cfg.lr = lr;
    }

    pub fn steps(&self) -> u64 {
        self.steps
    }

    /// One step with the gradients in `grads` (variables without a gradient are left alone).
    pub fn step(&mut self, grads: &GradStore) -> Result<()> {
        self.steps += 1;
        let c = self.cfg;
        let t = self.steps as i32;
        let bc1 = 1.0 - (c.beta1 as f64).powi(t);
        let bc2 = 1.0 - (c.beta2 as f64).powi(t);
        for ((_, var), (m, v)) in self
            .vars
            .iter()
            .zip(self.m.iter_mut().zip(self.v.iter_mut()))
        {
            let Some(g) = grads.get(var.as_tensor()) else {
                continue;
            };
            let r: candle_core::Result<()> = (|| {
                *m = ((m.affine(c.beta1 as f64, 0.0))? + g.affine(1.0 - c.beta1 as f64, 0.0)?)?;
                *v = ((v.affine(c.beta2 as f64, 0.0))?
                    + g.sqr()?.affine(1.0 - c.beta2 as f64, 0.0)?)?;
                let denom = v
                    .affine(1.0 / bc2, 0.0)?
                    .sqrt()?
                    .affine(1.0, c.eps as f64)?;
                let upd = m.affine(c.lr as f64 / bc1, 0.0)?.div(&denom)?;
                var.set(&var.as_tensor().sub(&upd)?)
            })();
            r.ctx("adam step")?;
        }
        Ok(())
    }

    /// Moments as named tensors (`adam.m.<var>`, `adam.v.<var>`).
    pub fn state(&self) -> Vec<(String, Tensor)> {
        let mut out = Vec::new();
        for ((name, _), (m, v)) in self.vars.iter().zip(self.m.iter().zip(&self.v)) {
            out.push((format!("adam.m.{name}"), m.clone()));
            out.push((format!("adam.v.{name}"), v.clone()));
        }
        out
    }

    /// Restores [`Adam::state`] and the step count.
    pub fn load_state(
        &mut self,
        t: &HashMap<String, Tensor>,
        steps: u64,
        path: &std::path::Path,
    ) -> Result<()> {
        for ((name, var), (m, v)) in self
            .vars
            .iter()
            .zip(self.m.iter_mut().zip(self.v.iter_mut()))
        {
            for (key, slot) in [(format!("adam.m.{name}"), m), (format!("adam.v.{name}"), v)] {
                let x = t.get(&key).ok_or_else(|| {
                    NeuralError::invalid(path, format!("checkpoint lacks `{key}`"))
                })?;
                if x.dims() != var.dims() {
                    return Err(NeuralError::invalid(
                        path,
                        format!(
                            "`{key}` has shape {:?}, expected {:?}",
                            x.dims(),
                            var.dims()
                        ),
                    ));
                }
                *slot = x.clone();
            }
        }
        self.steps = steps;
        Ok(())
    }
}
