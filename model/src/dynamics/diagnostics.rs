//! Energy, power and momentum of the last evaluated instant: the quantities
//! the conservation and energy-balance checks compare.

use super::model::Model;
use super::state::HeadState;
use super::workspace::Workspace;
use nalgebra::Vector3;

/// Energy and momentum diagnostics of the last evaluated instant.
#[derive(Debug, Clone, Copy, Default, PartialEq)]
pub struct Diagnostics {
    /// Kinetic energy of body and added fluid `∫ mu . I mu / 2` (J), in the
    /// frame moving with the water (`mu` relative to it; the ground frame
    /// in still water).
    pub energy: f64,
    /// Power delivered by the actuators `-∫ C . dK/dt` (W).
    pub actuator_power: f64,
    /// Energy flux through the tail plane `(V1 T_f)(1)` (W), with `V1`
    /// relative to the water.
    pub tail_flux: f64,
    /// Linear momentum of the body alone (earth frame).
    pub momentum: Vector3<f64>,
    /// Angular momentum of the body alone about the earth origin.
    pub angular_momentum: Vector3<f64>,
    /// Centre of mass of the body (earth frame).
    pub centre_of_mass: Vector3<f64>,
}

impl Workspace {
    /// Energy, power and momentum of the instant of the last [`evaluate`](super::evaluate) for
    /// `head` (after [`step`](super::step) the velocity fields are those of its last
    /// integration stage, so call [`evaluate`](super::evaluate) first).
    pub fn diagnostics(&self, model: &Model, head: &HeadState) -> Diagnostics {
        let r = head.orientation.to_rotation_matrix();
        let mut d = Diagnostics::default();
        let mut com = Vector3::zeros();
        for i in 0..=model.n {
            let s = &model.sec[i];
            let wi = model.w[i];
            let om = self.om_loc[i];
            let vl = self.v_loc[i];
            let mi = Vector3::from(s.mi);
            let mm = Vector3::from(s.mm);
            d.energy +=
                wi * 0.5 * (om.dot(&mi.component_mul(&om)) + vl.dot(&mm.component_mul(&vl)));
            let c = &self.curv[2 * i];
            d.actuator_power -=
                wi * (self.torque[i][0] * c.k_dot.y + self.torque[i][1] * c.k_dot.z);
            let pos = head.position + r * self.p[i];
            let vel = r * self.v[i];
            d.momentum += wi * s.mass * vel;
            let ib = Vector3::new(s.mi[0] - s.if1, s.mi[1], s.mi[2]);
            let ang = r * (self.q[i] * ib.component_mul(&om));
            d.angular_momentum += wi * (ang + pos.cross(&(s.mass * vel)));
            com += wi * s.mass * pos;
        }
        d.centre_of_mass = com / model.total_mass;
        let n = model.n;
        let s = &model.sec[n];
        let (om, vl) = (self.om_loc[n], self.v_loc[n]);
        let tf = 0.5 * (s.if1 * om.x * om.x + s.mf[1] * vl.y * vl.y + s.mf[2] * vl.z * vl.z);
        d.tail_flux = vl.x * tf;
        d
    }
}
