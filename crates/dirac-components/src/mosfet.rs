//! MOSFET, SPICE level 1 (Shichman–Hodges), as ngspice-39's `mos1` computes it.
//!
//! A level-1 MOSFET is a drain current `I_D(V_GS, V_DS, V_BS)` between drain and source
//! ([`MosfetChannel`]), two bulk junctions (bulk–drain and bulk–source [`Diode`]s: the ideal
//! junction current, `GMIN`, the bottom and sidewall depletion charges), three linear overlap capacitances
//! (`CGSO·W`, `CGDO·W`, `CGBO·L_eff`) and optional drain and source series resistances.
//! [`Mosfet::at_temperature`] computes all of them from a model card and an instance's geometry
//! at the circuit temperature; a netlist places them.
//!
//! Every charge of that list is a function of its own branch voltage, so each is a co-energy
//! and the device fits the variational formulation. The Meyer gate capacitances that ngspice
//! adds when the card gives `TOX` are not: the gate–source charge increments by `C_GS(V_GS,
//! V_DS, V_BS)·ΔV_GS` with a capacitance that depends on the other voltages (`devsup.c`,
//! `DEVqmeyer`), a charge that no function of the voltages has as its gradient. A card with
//! `TOX` is refused.
//!
//! Equations: `mos1load.c` (drain current and its regions), `mos1temp.c` (temperature),
//! `mos1set.c` (defaults); constants as in [`crate::Diode`].

use dirac_core::{ForceJacobian, Model};
use dirac_graph::Subsystem;
use thiserror::Error;

use crate::diode::{BOLTZMANN, CHARGE, K_OVER_Q, REFTEMP, ZERO_CELSIUS};
use crate::{
    Diode, DiodeError, DiodeParameters, ReverseCurrent, flux_branch_force, flux_branch_jacobian,
};

/// N- or p-channel (ngspice's `type`, +1 or −1).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Polarity {
    /// `NMOS`.
    N,
    /// `PMOS`.
    P,
}

impl Polarity {
    /// +1 for n-channel, −1 for p-channel.
    #[must_use]
    pub fn sign(self) -> f64 {
        match self {
            Self::N => 1.0,
            Self::P => -1.0,
        }
    }
}

/// A level-1 MOSFET model card (`.model NAME NMOS|PMOS (LEVEL=1 …)`), ngspice's names, SI
/// units, temperatures in °C, with ngspice's defaults.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct MosfetParameters {
    /// `NMOS` or `PMOS`.
    pub polarity: Polarity,
    /// `VTO`: zero-bias threshold voltage (V), default 0.
    pub vto: f64,
    /// `KP`: transconductance parameter (A/V²), default 2e-5.
    pub kp: f64,
    /// `GAMMA`: bulk threshold parameter (√V), default 0.
    pub gamma: f64,
    /// `PHI`: surface potential (V), default 0.6.
    pub phi: f64,
    /// `LAMBDA`: channel-length modulation (1/V), default 0.
    pub lambda: f64,
    /// `RD`, `RS`: drain and source ohmic resistances (Ω); `None` when not given.
    pub rd: Option<f64>,
    /// See [`MosfetParameters::rd`].
    pub rs: Option<f64>,
    /// `RSH`: drain and source diffusion sheet resistance (Ω/□), used when `RD`/`RS` are not
    /// given.
    pub rsh: Option<f64>,
    /// `CBD`, `CBS`: zero-bias bulk junction capacitances (F); when not given, `CJ` times the
    /// instance's area.
    pub cbd: Option<f64>,
    /// See [`MosfetParameters::cbd`].
    pub cbs: Option<f64>,
    /// `IS`: bulk junction saturation current (A), default 1e-14.
    pub is: f64,
    /// `JS`: bulk junction saturation current density (A/m²), default 0 (then `IS` applies).
    pub js: f64,
    /// `PB`: bulk junction potential (V), default 0.8.
    pub pb: f64,
    /// `CJ`: bottom junction capacitance per area (F/m²); `None` when not given.
    pub cj: Option<f64>,
    /// `MJ`: bottom grading coefficient, default 0.5.
    pub mj: f64,
    /// `CJSW`: sidewall junction capacitance per length (F/m); `None` when not given.
    pub cjsw: Option<f64>,
    /// `MJSW`: sidewall grading coefficient, default 0.5.
    pub mjsw: f64,
    /// `FC`: forward-bias depletion capacitance coefficient, default 0.5.
    pub fc: f64,
    /// `CGSO`, `CGDO` (F/m of width), `CGBO` (F/m of length): overlap capacitances, default 0.
    pub cgso: f64,
    /// See [`MosfetParameters::cgso`].
    pub cgdo: f64,
    /// See [`MosfetParameters::cgso`].
    pub cgbo: f64,
    /// `LD`: lateral diffusion (m), default 0.
    pub ld: f64,
    /// `TOX`: oxide thickness (m); `None` when not given. A non-zero `TOX` turns on the Meyer
    /// gate capacitances, which are not modelled (see the module's documentation).
    pub tox: Option<f64>,
    /// `TNOM`: temperature at which the parameters were measured (°C), default 27.
    pub tnom: f64,
}

impl MosfetParameters {
    /// ngspice's defaults for a card of `polarity`.
    #[must_use]
    pub fn new(polarity: Polarity) -> Self {
        Self {
            polarity,
            vto: 0.0,
            kp: 2e-5,
            gamma: 0.0,
            phi: 0.6,
            lambda: 0.0,
            rd: None,
            rs: None,
            rsh: None,
            cbd: None,
            cbs: None,
            is: 1e-14,
            js: 0.0,
            pb: 0.8,
            cj: None,
            mj: 0.5,
            cjsw: None,
            mjsw: 0.5,
            fc: 0.5,
            cgso: 0.0,
            cgdo: 0.0,
            cgbo: 0.0,
            ld: 0.0,
            tox: None,
            tnom: 27.0,
        }
    }
}

/// An `M` card's geometry (ngspice's instance parameters), with ngspice's defaults (`L` and `W`
/// 100 µm, the `.options` `DEFL`/`DEFW`).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct MosfetGeometry {
    /// `L`: channel length (m).
    pub l: f64,
    /// `W`: channel width (m).
    pub w: f64,
    /// `AD`, `AS`: drain and source diffusion areas (m²), default 0.
    pub ad: f64,
    /// See [`MosfetGeometry::ad`].
    pub as_: f64,
    /// `PD`, `PS`: drain and source perimeters (m), default 0.
    pub pd: f64,
    /// See [`MosfetGeometry::pd`].
    pub ps: f64,
    /// `NRD`, `NRS`: drain and source diffusion squares, default 1.
    pub nrd: f64,
    /// See [`MosfetGeometry::nrd`].
    pub nrs: f64,
    /// `M`: devices in parallel, default 1.
    pub m: f64,
}

impl Default for MosfetGeometry {
    fn default() -> Self {
        Self {
            l: 1e-4,
            w: 1e-4,
            ad: 0.0,
            as_: 0.0,
            pd: 0.0,
            ps: 0.0,
            nrd: 1.0,
            nrs: 1.0,
            m: 1.0,
        }
    }
}

/// Why a MOSFET cannot be built.
#[derive(Debug, Clone, PartialEq, Error)]
pub enum MosfetError {
    /// A parameter outside its domain, or a feature of the card this model does not carry.
    #[error("{parameter} = {value}: {reason}")]
    Parameter {
        /// The parameter's SPICE name.
        parameter: &'static str,
        /// Its value.
        value: f64,
        /// What is wrong with it.
        reason: &'static str,
    },
    /// A bulk junction's diode could not be built.
    #[error("bulk junction: {0}")]
    Junction(#[from] DiodeError),
}

/// The parts of one MOSFET at a temperature: what a netlist places between its four nodes.
#[derive(Debug, Clone, PartialEq)]
pub struct Mosfet {
    /// The drain current from the (inner) drain to the (inner) source.
    pub channel: MosfetChannel,
    /// The bulk–drain junction's diode card (anode at the bulk for an n-channel device, at the
    /// drain for a p-channel one), already at the temperature: its `TNOM` is the temperature,
    /// so [`Diode::at_temperature`] there builds it unchanged. `None` when it has neither
    /// current nor charge.
    pub drain_junction: Option<DiodeParameters>,
    /// The bulk–source junction, as [`Mosfet::drain_junction`].
    pub source_junction: Option<DiodeParameters>,
    /// Gate–source, gate–drain and gate–bulk overlap capacitances (F); zero ones are absent.
    pub overlap: [f64; 3],
    /// Drain and source series resistances (Ω); zero when absent (the inner node is the
    /// terminal).
    pub series: [f64; 2],
}

impl Mosfet {
    /// The device of card `p` with geometry `g` at `celsius` (°C), as `mos1temp.c` computes it.
    ///
    /// # Errors
    /// [`MosfetError::Parameter`] for `PHI ≤ 0`, a non-positive effective length or width, a
    /// negative capacitance, `FC ≥ 1`, or a `TOX` (Meyer capacitances, not modelled);
    /// [`MosfetError::Junction`] when a bulk junction cannot be built.
    pub fn at_temperature(
        p: &MosfetParameters,
        g: &MosfetGeometry,
        celsius: f64,
    ) -> Result<Self, MosfetError> {
        validate(p, g)?;
        let ty = p.polarity.sign();
        let tnom = p.tnom + ZERO_CELSIUS;
        let temp = celsius + ZERO_CELSIUS;
        let fact1 = tnom / REFTEMP;
        let vtnom = tnom * K_OVER_Q;
        let egfet1 = 1.16 - (7.02e-4 * tnom * tnom) / (tnom + 1108.0);
        let arg1 = -egfet1 / (2.0 * BOLTZMANN * tnom) + 1.115_087_7 / (BOLTZMANN * 2.0 * REFTEMP);
        let pbfact1 = -2.0 * vtnom * (1.5 * fact1.ln() + CHARGE * arg1);
        let vt = temp * K_OVER_Q;
        let ratio = temp / tnom;
        let fact2 = temp / REFTEMP;
        let egfet = 1.16 - (7.02e-4 * temp * temp) / (temp + 1108.0);
        let arg = -egfet / (2.0 * BOLTZMANN * temp) + 1.115_087_7 / (BOLTZMANN * 2.0 * REFTEMP);
        let pbfact = -2.0 * vt * (1.5 * fact2.ln() + CHARGE * arg);
        let kp = p.kp / (ratio * ratio.sqrt());
        let phio = (p.phi - pbfact1) / fact1;
        let phi = fact2 * phio + pbfact;
        let vbi = p.vto - ty * (p.gamma * p.phi.sqrt())
            + 0.5 * (egfet1 - egfet)
            + ty * 0.5 * (phi - p.phi);
        let leff = g.l - 2.0 * p.ld;
        if phi <= 0.0 {
            return Err(MosfetError::Parameter {
                parameter: "PHI",
                value: phi,
                reason: "the surface potential is not positive at this temperature",
            });
        }
        let channel = MosfetChannel {
            polarity: p.polarity,
            beta: kp * g.m * g.w / leff,
            vbi,
            phi,
            gamma: p.gamma,
            lambda: p.lambda,
        };
        // Bulk junctions: saturation current, potential and bottom capacitance.
        let sat_scale = (-egfet / vt + egfet1 / vtnom).exp();
        let by_density = p.js != 0.0 && g.ad != 0.0 && g.as_ != 0.0;
        let (drain_is, source_is) = if by_density {
            let js = p.js * sat_scale * g.m;
            (js * g.ad, js * g.as_)
        } else {
            let is = p.is * sat_scale * g.m;
            (is, is)
        };
        let pbo = (p.pb - pbfact1) / fact1;
        let gmaold = (p.pb - pbo) / pbo;
        let bulk_pot = fact2 * pbo + pbfact;
        let gmanew = (bulk_pot - pbo) / pbo;
        let capfact = |m: f64| {
            (1.0 + m * (4e-4 * (temp - REFTEMP) - gmanew))
                / (1.0 + m * (4e-4 * (tnom - REFTEMP) - gmaold))
        };
        let bottom = |given: Option<f64>, area: f64| match (given, p.cj) {
            (Some(c), _) => c * capfact(p.mj) * g.m,
            (None, Some(cj)) => cj * capfact(p.mj) * area * g.m,
            (None, None) => 0.0,
        };
        let sidewall = |perimeter: f64| p.cjsw.unwrap_or(0.0) * capfact(p.mjsw) * perimeter * g.m;
        let junction =
            |is: f64, cjo: f64, cjsw: f64| -> Result<Option<DiodeParameters>, MosfetError> {
                if is == 0.0 && cjo == 0.0 && cjsw == 0.0 {
                    return Ok(None);
                }
                // Parameters already at `celsius`: the diode's own temperature model is the
                // identity at its TNOM.
                let card = DiodeParameters {
                    cjo,
                    vj: bulk_pot,
                    m: p.mj,
                    fc: p.fc,
                    cjsw,
                    vjsw: bulk_pot,
                    mjsw: p.mjsw,
                    fcs: p.fc,
                    reverse: ReverseCurrent::Saturated,
                    tnom: celsius,
                    ..DiodeParameters::new(is, 1.0)
                };
                Diode::at_temperature(&card, celsius)?;
                Ok(Some(card))
            };
        let series = |given: Option<f64>, squares: f64| match (given, p.rsh) {
            (Some(r), _) => r / g.m,
            (None, Some(rsh)) => rsh * squares / g.m,
            (None, None) => 0.0,
        };
        Ok(Self {
            channel,
            drain_junction: junction(drain_is, bottom(p.cbd, g.ad), sidewall(g.pd))?,
            source_junction: junction(source_is, bottom(p.cbs, g.as_), sidewall(g.ps))?,
            overlap: [p.cgso * g.m * g.w, p.cgdo * g.m * g.w, p.cgbo * g.m * leff],
            series: [series(p.rd, g.nrd), series(p.rs, g.nrs)],
        })
    }
}

fn validate(p: &MosfetParameters, g: &MosfetGeometry) -> Result<(), MosfetError> {
    let fail = |parameter, value, reason| {
        Err(MosfetError::Parameter {
            parameter,
            value,
            reason,
        })
    };
    let values = [
        p.vto, p.kp, p.gamma, p.phi, p.lambda, p.is, p.js, p.pb, p.mj, p.mjsw, p.fc, p.cgso,
        p.cgdo, p.cgbo, p.ld, p.tnom, g.l, g.w, g.ad, g.as_, g.pd, g.ps, g.nrd, g.nrs, g.m,
    ];
    let optional = [p.rd, p.rs, p.rsh, p.cbd, p.cbs, p.cj, p.cjsw, p.tox];
    if let Some(v) = values
        .into_iter()
        .chain(optional.into_iter().flatten())
        .find(|v| !v.is_finite())
    {
        return fail("a model or instance parameter", v, "must be finite");
    }
    if let Some(tox) = p.tox.filter(|&t| t != 0.0) {
        return fail(
            "TOX",
            tox,
            "the Meyer gate capacitances a TOX turns on are not modelled (their charge is not a \
             function of the terminal voltages); give KP instead of TOX (and CGSO/CGDO for gate \
             capacitance)",
        );
    }
    if p.phi <= 0.0 {
        return fail("PHI", p.phi, "must be positive");
    }
    if g.l - 2.0 * p.ld <= 0.0 {
        return fail(
            "L",
            g.l,
            "the effective channel length L − 2·LD must be positive",
        );
    }
    for (parameter, value) in [("W", g.w), ("M", g.m)] {
        if value <= 0.0 {
            return fail(parameter, value, "must be positive");
        }
    }
    for (parameter, value) in [
        ("KP", p.kp),
        ("IS", p.is),
        ("JS", p.js),
        ("CGSO", p.cgso),
        ("CGDO", p.cgdo),
        ("CGBO", p.cgbo),
        ("CBD", p.cbd.unwrap_or(0.0)),
        ("CBS", p.cbs.unwrap_or(0.0)),
        ("CJ", p.cj.unwrap_or(0.0)),
        ("RD", p.rd.unwrap_or(0.0)),
        ("RS", p.rs.unwrap_or(0.0)),
        ("RSH", p.rsh.unwrap_or(0.0)),
        ("AD", g.ad),
        ("AS", g.as_),
        ("NRD", g.nrd),
        ("NRS", g.nrs),
    ] {
        if value < 0.0 {
            return fail(parameter, value, "must not be negative");
        }
    }
    if !(0.0..1.0).contains(&p.fc) {
        return fail("FC", p.fc, "must be in [0, 1)");
    }
    if p.pb <= 0.0 {
        return fail("PB", p.pb, "must be positive");
    }
    Ok(())
}

/// A level-1 drain current between drain and source, from the gate–source and bulk–source
/// voltages it senses (`mos1load.c`).
///
/// With `σ` the polarity's sign and the voltages multiplied by it, in normal mode (`V_DS ≥ 0`)
///
/// ```text
/// s = √(Φ − V_BS)                       V_BS ≤ 0
/// s = max(0, √Φ − V_BS/(2√Φ))           V_BS > 0
/// V_on = σ·V_bi + γ·s,   V_gst = V_GS − V_on
/// I = 0                                  V_gst ≤ 0
/// I = β(1 + λV_DS)·V_gst²/2              0 < V_gst ≤ V_DS
/// I = β(1 + λV_DS)·V_DS(V_gst − V_DS/2)  V_DS < V_gst
/// ```
///
/// and in inverse mode (`V_DS < 0`) the same with drain and source exchanged, the current
/// negated; the terminal current is `σ·I`. The Jacobian is the exact derivative (ngspice's
/// `gmbs` for `V_BS > 0` is not; the operating point is the same).
///
/// **Formulation**: an output branch (`q`, `φ`, port `i`) with `f_q = −φ̇`, `f_φ = I − q̇`, so
/// `φ̇` is `V_DS` and `q̇ = I`; two sensing branches as a behavioural source's (ports `ic0` for
/// gate–source, `ic1` for bulk–source).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct MosfetChannel {
    polarity: Polarity,
    /// `KP·M·W/L_eff` at the temperature (A/V²).
    beta: f64,
    /// The built-in voltage `V_bi` (ngspice's `tVbi`).
    vbi: f64,
    /// The surface potential at the temperature (V).
    phi: f64,
    gamma: f64,
    lambda: f64,
}

impl MosfetChannel {
    /// The port of the gate–source sensing branch.
    pub const GATE_PORT: &'static str = "ic0";
    /// The port of the bulk–source sensing branch.
    pub const BULK_PORT: &'static str = "ic1";

    /// The drain current from drain to source and its derivatives with respect to `V_GS`,
    /// `V_DS` and `V_BS` (terminal voltages, any polarity).
    #[must_use]
    pub fn current(&self, vgs: f64, vds: f64, vbs: f64) -> (f64, [f64; 3]) {
        let ty = self.polarity.sign();
        let (vgs, vds, vbs) = (ty * vgs, ty * vds, ty * vbs);
        if vds >= 0.0 {
            let (i, [gm, gds, gmbs]) = self.normal(vgs, vds, vbs);
            (ty * i, [gm, gds, gmbs])
        } else {
            // Drain and source exchanged: I(vgs, vds, vbs) = −i(vgs − vds, −vds, vbs − vds).
            let (i, [gm, gds, gmbs]) = self.normal(vgs - vds, -vds, vbs - vds);
            (-ty * i, [-gm, gm + gds + gmbs, -gmbs])
        }
    }

    /// `s` of the body effect at `vbs` (polarity applied) and `ds/dV_BS`.
    fn body(&self, vbs: f64) -> (f64, f64) {
        let root_phi = self.phi.sqrt();
        if vbs <= 0.0 {
            let s = (self.phi - vbs).sqrt();
            (s, -0.5 / s)
        } else {
            let s = root_phi - vbs / (2.0 * root_phi);
            if s > 0.0 {
                (s, -0.5 / root_phi)
            } else {
                (0.0, 0.0)
            }
        }
    }

    /// The threshold `V_on` at `vbs` (polarity applied).
    fn on_voltage(&self, vbs: f64) -> f64 {
        self.vbi * self.polarity.sign() + self.gamma * self.body(vbs).0
    }

    /// The normal-mode current (`vds ≥ 0`, polarity applied) and its partial derivatives.
    fn normal(&self, vgs: f64, vds: f64, vbs: f64) -> (f64, [f64; 3]) {
        let (sarg, dsarg) = self.body(vbs);
        let von = self.vbi * self.polarity.sign() + self.gamma * sarg;
        let vgst = vgs - von;
        if vgst <= 0.0 {
            return (0.0, [0.0; 3]);
        }
        let betap = self.beta * (1.0 + self.lambda * vds);
        let (i, gm, gds) = if vgst <= vds {
            let i = betap * vgst * vgst * 0.5;
            (i, betap * vgst, self.lambda * self.beta * vgst * vgst * 0.5)
        } else {
            let i = betap * vds * (vgst - 0.5 * vds);
            (
                i,
                betap * vds,
                betap * (vgst - vds) + self.lambda * self.beta * vds * (vgst - 0.5 * vds),
            )
        };
        // ∂I/∂V_BS = −gm·∂V_on/∂V_BS.
        (i, [gm, gds, -gm * self.gamma * dsarg])
    }

    /// This part as a subsystem named `name`: port `i` (drain to source), `ic0` (gate to
    /// source), `ic1` (bulk to source).
    pub fn subsystem(self, name: impl Into<String>) -> Subsystem {
        Subsystem::new(name, self)
            .with_port("i", 0)
            .with_port(Self::GATE_PORT, 2)
            .with_port(Self::BULK_PORT, 4)
    }
}

impl Model for MosfetChannel {
    fn dim(&self) -> usize {
        6
    }
    zero_lagrangian!();
    fn has_force(&self) -> bool {
        true
    }
    fn force(&self, _q: &[f64], v: &[f64], _t: f64, f: &mut [f64]) {
        let (i, _) = self.current(v[3], v[1], v[5]);
        for at in [0, 2, 4] {
            flux_branch_force(v, at, f);
        }
        f[1] += i;
    }
    fn force_jacobian(&self, _q: &[f64], v: &[f64], _t: f64, j: &mut ForceJacobian) {
        let (_, [gm, gds, gmbs]) = self.current(v[3], v[1], v[5]);
        for at in [0, 2, 4] {
            flux_branch_jacobian(at, j);
        }
        j.v.add(1, 3, gm);
        j.v.add(1, 1, gds);
        j.v.add(1, 5, gmbs);
    }
    fn has_update_limit(&self) -> bool {
        true
    }
    /// ngspice's `DEVfetlim` on the gate voltage against the source (drain in inverse mode) and
    /// `DEVlimvds` on the drain–source voltage (`mos1load.c`), as the fraction of the update
    /// that keeps both within their limits: a Newton step from a cut-off or reversed device
    /// cannot jump across the threshold and the mode boundary in one go.
    fn update_fraction(&self, _q: &[f64], v: &[f64], _dq: &[f64], dv: &[f64]) -> f64 {
        let ty = self.polarity.sign();
        let (vds, vgs, vbs) = (ty * v[1], ty * v[3], ty * v[5]);
        let (dds, dgs) = (ty * dv[1], ty * dv[3]);
        let mut alpha = 1.0_f64;
        let mut keep = |old: f64, step: f64, limited: f64| {
            if step != 0.0 && limited != old + step {
                let a = (limited - old) / step;
                if a > 0.0 && a <= 1.0 {
                    alpha = alpha.min(a);
                }
            }
        };
        if vds >= 0.0 {
            let von = self.on_voltage(vbs);
            keep(vgs, dgs, fetlim(vgs + dgs, vgs, von));
            keep(vds, dds, limvds(vds + dds, vds));
        } else {
            let von = self.on_voltage(vbs - vds);
            let (vgd, dgd) = (vgs - vds, dgs - dds);
            keep(vgd, dgd, fetlim(vgd + dgd, vgd, von));
            keep(-vds, -dds, limvds(-(vds + dds), -vds));
        }
        alpha
    }
    fn coordinate_name(&self, i: usize) -> String {
        ["q", "phi", "q_gs", "phi_gs", "q_bs", "phi_bs"]
            .get(i)
            .map_or_else(|| format!("q{i}"), |s| (*s).to_owned())
    }
}

/// ngspice's `DEVfetlim` (`devsup.c`): the gate voltage `vnew` an iteration may move to from
/// `vold`, given the threshold `vto`.
fn fetlim(vnew: f64, vold: f64, vto: f64) -> f64 {
    let vtsthi = (2.0 * (vold - vto)).abs() + 2.0;
    let vtstlo = (vold - vto).abs() + 1.0;
    let vtox = vto + 3.5;
    let delv = vnew - vold;
    if vold >= vto {
        if vold >= vtox {
            if delv <= 0.0 {
                // Going off.
                if vnew >= vtox {
                    if -delv > vtstlo {
                        return vold - vtstlo;
                    }
                    vnew
                } else {
                    vnew.max(vto + 2.0)
                }
            } else if delv >= vtsthi {
                // Staying on.
                vold + vtsthi
            } else {
                vnew
            }
        } else if delv <= 0.0 {
            // Middle region, decreasing.
            vnew.max(vto - 0.5)
        } else {
            vnew.min(vto + 4.0)
        }
    } else if delv <= 0.0 {
        // Off.
        if -delv > vtsthi { vold - vtsthi } else { vnew }
    } else {
        let vtemp = vto + 0.5;
        if vnew <= vtemp {
            if delv > vtstlo { vold + vtstlo } else { vnew }
        } else {
            vtemp
        }
    }
}

/// ngspice's `DEVlimvds` (`devsup.c`): the drain–source voltage an iteration may move to.
fn limvds(vnew: f64, vold: f64) -> f64 {
    if vold >= 3.5 {
        if vnew > vold {
            vnew.min(3.0 * vold + 2.0)
        } else if vnew < 3.5 {
            vnew.max(2.0)
        } else {
            vnew
        }
    } else if vnew > vold {
        vnew.min(4.0)
    } else {
        vnew.max(-0.5)
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::testing::check_model;

    fn nmos() -> MosfetParameters {
        MosfetParameters {
            vto: 0.7,
            kp: 110e-6,
            gamma: 0.4,
            phi: 0.7,
            lambda: 0.04,
            ..MosfetParameters::new(Polarity::N)
        }
    }

    fn channel(p: &MosfetParameters) -> MosfetChannel {
        let g = MosfetGeometry {
            w: 10e-6,
            l: 1e-6,
            ..MosfetGeometry::default()
        };
        Mosfet::at_temperature(p, &g, 27.0).unwrap().channel
    }

    /// The square law by hand at the nominal temperature (β = KP·W/L = 1.1 mA/V²): saturation
    /// at V_GS = 2, V_DS = 3, V_BS = 0 is β/2·1.3²·(1 + 0.12) = 1.04104 mA; triode at V_DS = 0.5
    /// is β·1.02·0.5·(1.3 − 0.25) = 0.58905 mA; body effect at V_BS = −1 raises V_on by
    /// γ(√1.7 − √0.7); cut-off below V_on. A p-channel device of the same card mirrors it.
    #[test]
    fn square_law_by_hand() {
        let ch = channel(&nmos());
        let beta = 110e-6 * 10.0;
        let close = |a: f64, b: f64| (a - b).abs() <= 1e-14 * b.abs().max(1e-6);
        assert!(close(
            ch.current(2.0, 3.0, 0.0).0,
            beta / 2.0 * 1.3 * 1.3 * 1.12
        ));
        assert!(close(ch.current(2.0, 0.5, 0.0).0, beta * 1.02 * 0.5 * 1.05));
        let von = 0.7 + 0.4 * (1.7f64.sqrt() - 0.7f64.sqrt());
        let body = beta / 2.0 * (2.0 - von).powi(2) * 1.12;
        assert!(close(ch.current(2.0, 3.0, -1.0).0, body));
        assert_eq!(ch.current(0.6, 3.0, 0.0).0, 0.0);
        // Drain and source exchanged: the current reverses.
        let (fwd, _) = ch.current(2.0, 0.5, 0.0);
        let (rev, _) = ch.current(1.5, -0.5, -0.5);
        assert!(close(rev, -fwd));
        let p = channel(&MosfetParameters {
            vto: -0.7,
            ..MosfetParameters {
                polarity: Polarity::P,
                ..nmos()
            }
        });
        assert!(close(
            p.current(-2.0, -3.0, 0.0).0,
            -beta / 2.0 * 1.3 * 1.3 * 1.12
        ));
    }

    /// The Jacobian is the derivative of the current in every region and both modes, against
    /// central differences (the shared model check), including `V_BS > 0`.
    #[test]
    fn jacobians_match_differences() {
        for p in [
            nmos(),
            MosfetParameters {
                polarity: Polarity::P,
                vto: -0.7,
                ..nmos()
            },
        ] {
            let part = channel(&p);
            let s = p.polarity.sign();
            for (vgs, vds, vbs) in [
                (2.0, 3.0, -1.0),
                (2.0, 0.4, -0.3),
                (2.0, -0.4, 0.2),
                (1.5, -3.0, 0.0),
                (2.0, 1.0, 0.3),
                (0.2, 1.0, -0.5),
            ] {
                let v = [1e-3, s * vds, 2e-3, s * vgs, -1e-3, s * vbs];
                check_model(&part, &[0.0; 6], &v, 0.0);
            }
        }
    }

    /// At 27 °C against TNOM = 27 °C nothing changes; away from it `KP` scales as `(T/Tnom)^−1.5`
    /// (`mos1temp.c`), and `V_on` moves by the temperature change of `Φ` and the band gap.
    #[test]
    fn temperature() {
        let p = nmos();
        let g = MosfetGeometry::default();
        let at = |c: f64| Mosfet::at_temperature(&p, &g, c).unwrap().channel;
        let nominal = at(27.0);
        assert!((nominal.vbi - (0.7 - 0.4 * 0.7f64.sqrt())).abs() < 1e-14);
        assert!((nominal.phi - 0.7).abs() < 1e-14);
        let hot = at(127.0);
        let ratio: f64 = (127.0 + 273.15) / 300.15;
        assert!((hot.beta / nominal.beta - ratio.powf(-1.5)).abs() < 1e-14);
        assert!(hot.phi < nominal.phi);
    }

    /// What the netlist refuses: Meyer capacitances (TOX), a channel shorter than twice its
    /// lateral diffusion.
    #[test]
    fn refused_cards() {
        let g = MosfetGeometry::default();
        let tox = MosfetParameters {
            tox: Some(1e-8),
            ..nmos()
        };
        assert!(matches!(
            Mosfet::at_temperature(&tox, &g, 27.0),
            Err(MosfetError::Parameter {
                parameter: "TOX",
                ..
            })
        ));
        let short = MosfetParameters {
            ld: 0.6e-4,
            ..nmos()
        };
        assert!(Mosfet::at_temperature(&short, &g, 27.0).is_err());
    }

    /// Overlap capacitances and series resistances from the geometry (`mos1load.c`,
    /// `mos1temp.c`): `CGSO·M·W`, `CGBO·M·L_eff`, `RSH·NRD/M`.
    #[test]
    fn geometry() {
        let p = MosfetParameters {
            cgso: 2e-10,
            cgbo: 1e-10,
            rsh: Some(20.0),
            rs: Some(5.0),
            ld: 0.1e-6,
            cj: Some(1e-4),
            ..nmos()
        };
        let g = MosfetGeometry {
            w: 10e-6,
            l: 1e-6,
            ad: 2e-11,
            nrd: 3.0,
            m: 2.0,
            ..MosfetGeometry::default()
        };
        let d = Mosfet::at_temperature(&p, &g, 27.0).unwrap();
        assert!((d.overlap[0] - 2e-10 * 2.0 * 10e-6).abs() < 1e-25);
        assert_eq!(d.overlap[1], 0.0);
        assert!((d.overlap[2] - 1e-10 * 2.0 * 0.8e-6).abs() < 1e-25);
        assert_eq!(d.series, [30.0, 2.5]);
        let cj = |j: Option<DiodeParameters>| j.map(|j| j.cjo);
        assert!(cj(d.drain_junction).is_some_and(|c| (c - 1e-4 * 2e-11 * 2.0).abs() < 1e-27));
        assert_eq!(cj(d.source_junction), Some(0.0));
        // Sidewall: CJSW·PS·M on the source junction, with its own grading and the bulk potential.
        let side = Mosfet::at_temperature(
            &MosfetParameters {
                cjsw: Some(3e-10),
                mjsw: 0.33,
                ..p
            },
            &MosfetGeometry { ps: 5e-6, ..g },
            27.0,
        )
        .unwrap();
        let j = side.source_junction.unwrap();
        assert!((j.cjsw - 3e-10 * 5e-6 * 2.0).abs() < 1e-27);
        assert_eq!((j.mjsw, j.vjsw, j.fcs), (0.33, j.vj, p.fc));
        assert_eq!(side.drain_junction.unwrap().cjsw, 0.0);
    }
}
