//! Junction diode: SPICE level 1 as ngspice computes it, written on the branch charge and the
//! junction flux linkage.
//!
//! Equations follow ngspice 39 (`src/spicelib/devices/dio/dioload.c` for the current and the
//! junction charge, `diotemp.c` for the temperature adjustment and the breakdown knee,
//! `devsup.c` for `DEVpnjlim`); the physical constants are ngspice's (`src/include/ngspice/const.h`).

use dirac_core::{ForceJacobian, LagrangianHessian, Model};
use dirac_graph::Subsystem;
use thiserror::Error;

/// Boltzmann's constant as ngspice 39 uses it (J/K).
pub(crate) const BOLTZMANN: f64 = 1.380_648_52e-23;
/// The elementary charge as ngspice 39 uses it (C).
pub(crate) const CHARGE: f64 = 1.602_176_620_8e-19;
/// `k/q` (V/K).
pub(crate) const K_OVER_Q: f64 = BOLTZMANN / CHARGE;
/// 0 °C in kelvin.
pub(crate) const ZERO_CELSIUS: f64 = 273.15;
/// SPICE's reference temperature, 27 °C (K).
pub(crate) const REFTEMP: f64 = 27.0 + ZERO_CELSIUS;
/// ngspice's `CKTepsmin`: the smallest saturation current it accepts (A).
const IS_MIN: f64 = 1e-28;
/// ngspice's limit on the temperature-adjusted grading coefficient (`DIOgradingCoeffMax`).
const GRADING_MAX: f64 = 0.9;
/// ngspice's default `RELTOL`, which sets the accuracy of the breakdown knee match in `diotemp.c`.
const BREAKDOWN_MATCH_RELTOL: f64 = 1e-3;
/// Iterations of the breakdown knee match in `diotemp.c`.
const BREAKDOWN_MATCH_ITERATIONS: usize = 25;

/// Below this `|x|` the series of `eˣ − 1 − x` and `(1 − x)ᵏ`-differences are used (their direct
/// forms cancel): six terms reach round-off.
const SERIES: f64 = 1e-3;

/// A diode model card: SPICE level-1 parameters as written on `.model NAME D(...)` (ngspice's
/// names, SI units, temperatures in °C), with ngspice's defaults.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct DiodeParameters {
    /// `IS`: saturation current (A), default 1e-14.
    pub is: f64,
    /// `N`: emission coefficient, default 1.
    pub n: f64,
    /// `RS`: series resistance (Ω), default 0.
    pub rs: f64,
    /// `CJO`: zero-bias depletion capacitance (F), default 0.
    pub cjo: f64,
    /// `VJ`: junction potential (V), default 1.
    pub vj: f64,
    /// `M`: grading coefficient, default 0.5.
    pub m: f64,
    /// `FC`: forward-bias depletion capacitance coefficient, default 0.5.
    pub fc: f64,
    /// `TT`: transit time (s), default 0.
    pub tt: f64,
    /// `BV`: reverse breakdown voltage (V, positive); none by default (no breakdown).
    pub bv: Option<f64>,
    /// `IBV`: current at the breakdown voltage (A), default 1e-3.
    pub ibv: f64,
    /// `NBV`: breakdown emission coefficient; `N` when not given.
    pub nbv: Option<f64>,
    /// `EG`: activation energy (eV), default 1.11.
    pub eg: f64,
    /// `XTI`: saturation-current temperature exponent, default 3.
    pub xti: f64,
    /// `TNOM`: temperature at which the parameters were measured (°C), default 27.
    pub tnom: f64,
    /// `TCV`: linear temperature coefficient of `BV` (V/K), default 0.
    pub tcv: f64,
    /// `TRS1`, `TRS2`: temperature coefficients of `RS` (1/K, 1/K²), default 0.
    pub trs: [f64; 2],
    /// `TTT1`, `TTT2`: temperature coefficients of `TT` (1/K, 1/K²), default 0.
    pub ttt: [f64; 2],
    /// `TM1`, `TM2`: temperature coefficients of `M` (1/K, 1/K²), default 0.
    pub tm: [f64; 2],
    /// `AREA`: area factor scaling `IS` and `CJO` and dividing `RS`, default 1.
    pub area: f64,
    /// Sidewall depletion capacitance (F), default 0: a second depletion term with its own
    /// potential, grading and knee, added to the bottom one (a MOSFET's junction `CJSW·PD`).
    /// A netlist's `D` card does not set it: ngspice-39's diode evaluates its sidewall charge
    /// above the knee with the bottom term's `F1` (`dioload.c`), which is not continuous.
    pub cjsw: f64,
    /// Sidewall junction potential (V), default 1.
    pub vjsw: f64,
    /// Sidewall grading coefficient, default 0.33.
    pub mjsw: f64,
    /// Sidewall forward-bias depletion capacitance coefficient, default 0.5.
    pub fcs: f64,
    /// The current below `−3·N·V_t` (and above the breakdown knee): a junction diode's cubic
    /// approach to `−I_S` by default, or `−I_S` itself, as ngspice's MOSFET junctions compute it.
    pub reverse: ReverseCurrent,
    /// Whether the junction carries its diode current (true by default). False: only its
    /// charges and `GMIN`, a BJT's substrate junction (ngspice-39's `ISS` is 0 there), where the
    /// floor `IS` of 1e-28 A a diode card gets would conduct milliamperes once forward biased
    /// by 1.5 V.
    pub conducts: bool,
}

/// How a junction's current approaches `−I_S` below `−3·N·V_t`.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub enum ReverseCurrent {
    /// `−I_S(1 + (3NV_t/(e·v))³)`, continuous with its slope at `−3NV_t` (`dioload.c`).
    #[default]
    Cubic,
    /// `−I_S` (`mos1load.c`'s bulk junctions): the current steps by `e⁻³·I_S` at `−3NV_t`.
    Saturated,
}

impl Default for DiodeParameters {
    fn default() -> Self {
        Self {
            is: 1e-14,
            n: 1.0,
            rs: 0.0,
            cjo: 0.0,
            vj: 1.0,
            m: 0.5,
            fc: 0.5,
            tt: 0.0,
            bv: None,
            ibv: 1e-3,
            nbv: None,
            eg: 1.11,
            xti: 3.0,
            tnom: 27.0,
            tcv: 0.0,
            trs: [0.0; 2],
            ttt: [0.0; 2],
            tm: [0.0; 2],
            area: 1.0,
            cjsw: 0.0,
            vjsw: 1.0,
            mjsw: 0.33,
            fcs: 0.5,
            reverse: ReverseCurrent::Cubic,
            conducts: true,
        }
    }
}

impl DiodeParameters {
    /// A plain junction: saturation current `is`, emission coefficient `n`, everything else at
    /// ngspice's defaults.
    #[must_use]
    pub fn new(is: f64, n: f64) -> Self {
        Self {
            is,
            n,
            ..Self::default()
        }
    }
}

/// A diode parameter that cannot be used.
#[derive(Debug, Clone, PartialEq, Error)]
#[error("diode parameter {parameter} = {value}: {reason}")]
pub struct DiodeError {
    /// The parameter's SPICE name.
    pub parameter: &'static str,
    /// Its value.
    pub value: f64,
    /// What is wrong with it.
    pub reason: &'static str,
}

/// Junction diode (SPICE level 1, as ngspice computes it) with series resistance, junction
/// charge and a conductance `GMIN` across the junction.
///
/// **Formulation.** The part has two coordinates: the branch charge `q` (port `i`, current from
/// anode `+` to cathode `−`) and the junction flux linkage `φ`, whose rate is the junction
/// voltage `φ̇ = v_j`. Its Lagrangian is the co-energy of the junction charge `Q_j(v)`
/// (depletion and diffusion), its forces the junction current and the series resistance:
///
/// ```text
/// L(φ̇) = ∫₀^φ̇ Q_j(u) du,         p_φ = Q_j(v_j),
/// f_q  = −φ̇ − R_S q̇,              f_φ = q̇ − i_D(φ̇) − GMIN·φ̇.
/// ```
///
/// The `φ` equation is `dQ_j/dt = q̇ − i_D(v_j) − GMIN·v_j` (the branch current charges the
/// junction and flows through it), the `q` equation makes the terminal voltage `v_j + R_S q̇`.
/// Newton's unknowns are a current and a voltage, both well scaled at every `I_S` (a
/// parametrisation by the current, or by anything proportional to `I_S`, makes the reverse branch
/// flat below round-off). The stored energy `φ̇ p_φ − L = ∫₀^{v_j} u dQ_j(u) ≥ 0` and the forces'
/// power `−R_S q̇² − v_j i_D(v_j) − GMIN v_j² ≤ 0` at every state: the diode never produces energy.
/// Without junction charge (`CJO = TT = 0`) `L = 0` and `φ` is a degenerate coordinate fixed by
/// `f_φ = 0`.
///
/// **Current** (`dioload.c`), `V_te = N·kT/q`, `V_tb = NBV·kT/q`:
///
/// ```text
/// i_D = I_S (e^{v/V_te} − 1)                 v ≥ −3 V_te
/// i_D = −I_S (1 + (3 V_te/(e·v))³)            −BV_eff ≤ v < −3 V_te
/// i_D = −I_S e^{−(BV_eff + v)/V_tb}           v < −BV_eff
/// ```
///
/// (`BV_eff` adjusted from `BV` so the breakdown current at `−BV` is `IBV`, as `diotemp.c` does.)
///
/// **Charge**: depletion `CJO`, `VJ`, `M` (with the linear extension above `FC·VJ`) plus diffusion
/// `TT·(i_D + GMIN·v)`. **Temperature**: `IS`, `VJ`, `CJO`, `M`, `TT`, `RS`, `BV` adjusted from
/// `TNOM` to the circuit temperature as `diotemp.c` does.
///
/// **Newton.** [`Model::update_fraction`] limits the junction voltage per iteration as
/// `DEVpnjlim` does, expressed as a fraction of the whole update.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Diode {
    is: f64,
    vt: f64,
    vte: f64,
    vtb: f64,
    /// The matched breakdown voltage `BV_eff` (positive), if breakdown is modelled.
    bv: Option<f64>,
    rs: f64,
    /// The bottom depletion charge (`CJO`, `VJ`, `M`, `FC`).
    bottom: Depletion,
    /// The sidewall depletion charge (zero capacitance unless given).
    sidewall: Depletion,
    reverse: ReverseCurrent,
    tt: f64,
    vcrit: f64,
    gmin: f64,
}

/// One depletion charge term (`dioload.c`, `mos1load.c`): `CJO·VJ(1 − (1 − v/VJ)^{1−M})/(1 − M)`
/// below the knee `FC·VJ`, continued above it by the parabola whose capacitance is linear in `v`.
#[derive(Debug, Clone, Copy, PartialEq)]
pub(crate) struct Depletion {
    cj0: f64,
    vj: f64,
    m: f64,
    /// `VJ(1 − (1 − FC)^{1−M})/(1 − M)`.
    f1: f64,
    /// `(1 − FC)^{1+M}`.
    f2: f64,
    /// `1 − FC(1 + M)`.
    f3: f64,
    /// `FC·VJ`: where the charge switches to its linear-capacitance extension.
    knee: f64,
}

impl Depletion {
    pub(crate) fn new(cj0: f64, vj: f64, m: f64, fc: f64) -> Self {
        let xfc = (1.0 - fc).ln();
        Self {
            cj0,
            vj,
            m,
            f1: vj * (1.0 - ((1.0 - m) * xfc).exp()) / (1.0 - m),
            f2: ((1.0 + m) * xfc).exp(),
            f3: 1.0 - fc * (1.0 + m),
            knee: fc * vj,
        }
    }

    /// The charge `Q_d(v)` and capacitance `dQ_d/dv`.
    pub(crate) fn charge(&self, v: f64) -> (f64, f64) {
        if self.cj0 == 0.0 {
            return (0.0, 0.0);
        }
        let (cj0, vj, m) = (self.cj0, self.vj, self.m);
        if v < self.knee {
            // Q = VJ·CJO·(1 − (1 − v/VJ)^{1−M})/(1 − M), written without cancellation.
            let l = (-v / vj).ln_1p();
            let q = -vj * cj0 * ((1.0 - m) * l).exp_m1() / (1.0 - m);
            (q, cj0 * (-m * l).exp())
        } else {
            let d = self.knee;
            let czof2 = cj0 / self.f2;
            let q = cj0 * self.f1 + czof2 * (self.f3 * (v - d) + m / (2.0 * vj) * (v * v - d * d));
            (q, czof2 * (self.f3 + m * v / vj))
        }
    }

    /// `∫₀^v Q_d(u) du`, in closed form.
    pub(crate) fn integral(&self, v: f64) -> f64 {
        if self.cj0 == 0.0 {
            return 0.0;
        }
        let (cj0, vj, m) = (self.cj0, self.vj, self.m);
        // ∫₀^v Q_d = VJ·CJO/(1−M) · VJ · (x − (1 − (1 − x)^{2−M})/(2 − M)), x = v/VJ.
        let below = |v: f64| {
            let x = v / vj;
            let k = 2.0 - m;
            let bracket = if x.abs() < SERIES {
                // x − (1 − (1−x)^k)/k = Σ_{j≥2} −C(k, j)(−x)^j / k.
                let mut sum = 0.0;
                let mut binom = k; // C(k, 1)
                let mut power = -x;
                for j in 2..8 {
                    binom *= (k - f64::from(j - 1)) / f64::from(j);
                    power *= -x;
                    sum += binom * power / k;
                }
                sum
            } else {
                x + (k * (-x).ln_1p()).exp_m1() / k
            };
            vj * cj0 / (1.0 - m) * vj * bracket
        };
        let d = self.knee;
        if v <= d {
            return below(v);
        }
        let czof2 = cj0 / self.f2;
        let w = v - d;
        below(d)
            + cj0 * self.f1 * w
            + czof2
                * (0.5 * self.f3 * w * w
                    + m / (2.0 * vj) * ((v * v * v - d * d * d) / 3.0 - d * d * w))
    }
}

/// What [`Diode::at_temperature`] built, with the adjustments ngspice would warn about.
#[derive(Debug, Clone, PartialEq)]
pub struct DiodeBuild {
    /// The diode at the requested temperature.
    pub diode: Diode,
    /// Parameters limited as ngspice limits them (grading coefficient, junction potential).
    pub warnings: Vec<String>,
}

impl Diode {
    /// ngspice's default `GMIN` (S), placed across every junction.
    pub const GMIN: f64 = 1e-12;

    /// The thermal voltage `kT/q` at `celsius` (°C), with ngspice's constants.
    #[must_use]
    pub fn thermal_voltage_at(celsius: f64) -> f64 {
        K_OVER_Q * (celsius + ZERO_CELSIUS)
    }

    /// The diode of card `p` at circuit temperature `celsius` (°C) with `GMIN` = [`Diode::GMIN`].
    ///
    /// # Errors
    /// A parameter outside its domain (negative capacitance, `FC ≥ 1`, …).
    pub fn at_temperature(p: &DiodeParameters, celsius: f64) -> Result<DiodeBuild, DiodeError> {
        validate(p, celsius)?;
        let mut warnings = Vec::new();
        let temp = celsius + ZERO_CELSIUS;
        let tnom = p.tnom + ZERO_CELSIUS;
        let vt = K_OVER_Q * temp;
        let vte = p.n * vt;
        let vtnom = K_OVER_Q * tnom;
        let dt = temp - tnom;
        let mut m = p.m * (1.0 + p.tm[0] * dt + p.tm[1] * dt * dt);
        if m > GRADING_MAX {
            warnings.push(format!(
                "temperature-adjusted grading coefficient M = {m} too large, limited to {GRADING_MAX} (as ngspice does)"
            ));
            m = GRADING_MAX;
        }
        // Junction potentials and capacitances (diotemp.c, TLEVC = 0), bottom and sidewall.
        let fact2 = temp / REFTEMP;
        let egfet = 1.16 - (7.02e-4 * temp * temp) / (temp + 1108.0);
        let arg = -egfet / (2.0 * BOLTZMANN * temp) + 1.115_087_7 / (BOLTZMANN * 2.0 * REFTEMP);
        let pbfact = -2.0 * vt * (1.5 * fact2.ln() + CHARGE * arg);
        let egfet1 = 1.16 - (7.02e-4 * tnom * tnom) / (tnom + 1108.0);
        let arg1 = -egfet1 / (BOLTZMANN * 2.0 * tnom) + 1.115_087_7 / (2.0 * BOLTZMANN * REFTEMP);
        let fact1 = tnom / REFTEMP;
        let pbfact1 = -2.0 * vtnom * (1.5 * fact1.ln() + CHARGE * arg1);
        let adjusted = |cj: f64, vj: f64, m: f64| {
            let pbo = (vj - pbfact1) / fact1;
            let gmaold = (vj - pbo) / pbo;
            let tvj = pbfact + fact2 * pbo;
            let gmanew = (tvj - pbo) / pbo;
            let tcj = cj / (1.0 + m * (400e-6 * (tnom - REFTEMP) - gmaold))
                * (1.0 + m * (400e-6 * (temp - REFTEMP) - gmanew));
            (tcj, tvj)
        };
        let (cj0, mut vj) = adjusted(p.cjo * p.area, p.vj, m);
        let (cjsw, mut vjsw) = adjusted(p.cjsw, p.vjsw, p.mjsw);
        // Saturation current.
        let arg1 = (temp / tnom - 1.0) * p.eg / vte;
        let arg2 = p.xti / p.n * (temp / tnom).ln();
        let is = if p.conducts {
            p.is.max(IS_MIN) * p.area * (arg1 + arg2).exp()
        } else {
            0.0
        };
        let vcrit = if is > 0.0 {
            vte * (vte / (std::f64::consts::SQRT_2 * is)).ln()
        } else {
            f64::INFINITY
        };
        if p.fc * vj > 1.0 {
            warnings.push(format!(
                "junction potential VJ = {vj} too large for FC = {}, limited to {} (as ngspice does)",
                p.fc,
                1.0 / p.fc
            ));
            vj = 1.0 / p.fc;
        }
        if cjsw > 0.0 && p.fcs * vjsw > 1.0 {
            warnings.push(format!(
                "sidewall junction potential {vjsw} too large for its FC = {}, limited to {} (as \
                 ngspice does)",
                p.fcs,
                1.0 / p.fcs
            ));
            vjsw = 1.0 / p.fcs;
        }
        let nbv = p.nbv.unwrap_or(p.n);
        let bv =
            p.bv.map(|bv| breakdown_knee(bv - p.tcv * dt, p.ibv, is, vt, nbv));
        let tt = p.tt * (1.0 + p.ttt[0] * dt + p.ttt[1] * dt * dt);
        let rs = if p.rs == 0.0 {
            0.0
        } else {
            p.rs * (1.0 + p.trs[0] * dt + p.trs[1] * dt * dt) / p.area
        };
        if cj0 < 0.0 || cjsw < 0.0 || tt < 0.0 || rs < 0.0 || vj <= 0.0 || vjsw <= 0.0 {
            return Err(DiodeError {
                parameter: "TNOM/temperature coefficients",
                value: celsius,
                reason: "the temperature adjustment makes CJO, TT or RS negative or VJ non-positive at this temperature",
            });
        }
        Ok(DiodeBuild {
            diode: Self {
                is,
                vt,
                vte,
                vtb: nbv * vt,
                bv,
                rs,
                bottom: Depletion::new(cj0, vj, m, p.fc),
                sidewall: Depletion::new(cjsw, vjsw, p.mjsw, p.fcs),
                reverse: p.reverse,
                tt,
                vcrit,
                gmin: Self::GMIN,
            },
            warnings,
        })
    }

    /// The same diode with conductance `gmin` (S, ≥ 0) across the junction instead of
    /// [`Diode::GMIN`] (ngspice's `.options gmin`).
    #[must_use]
    pub fn with_gmin(mut self, gmin: f64) -> Self {
        self.gmin = gmin.max(0.0);
        self
    }

    /// The temperature-adjusted saturation current `I_S` (A).
    #[must_use]
    pub fn saturation_current(&self) -> f64 {
        self.is
    }

    /// The thermal voltage `kT/q` at the diode's temperature (V).
    #[must_use]
    pub fn thermal_voltage(&self) -> f64 {
        self.vt
    }

    /// The breakdown voltage matched to `IBV` (`BV_eff`, positive), if breakdown is modelled.
    #[must_use]
    pub fn breakdown_voltage(&self) -> Option<f64> {
        self.bv
    }

    /// The series resistance at the diode's temperature (Ω).
    #[must_use]
    pub fn series_resistance(&self) -> f64 {
        self.rs
    }

    /// The conductance across the junction (S).
    #[must_use]
    pub fn gmin(&self) -> f64 {
        self.gmin
    }

    /// ngspice's `V_crit = V_te ln(V_te / (√2 I_S))`, where junction limiting starts.
    #[must_use]
    pub fn critical_voltage(&self) -> f64 {
        self.vcrit
    }

    /// Whether the junction stores charge (`CJO > 0` or `TT > 0`): otherwise `φ` is degenerate.
    #[must_use]
    pub fn has_charge(&self) -> bool {
        self.bottom.cj0 > 0.0 || self.sidewall.cj0 > 0.0 || self.tt > 0.0
    }

    /// The junction current `i_D(v)` without `GMIN` and its derivative `di_D/dv`.
    #[must_use]
    pub fn shockley(&self, v: f64) -> (f64, f64) {
        let vte = self.vte;
        if self.is == 0.0 {
            return (0.0, 0.0);
        }
        if v >= -3.0 * vte {
            let x = v / vte;
            (self.is * x.exp_m1(), self.is * x.exp() / vte)
        } else {
            match self.bv {
                Some(bv) if v < -bv => {
                    let e = (-(bv + v) / self.vtb).exp();
                    (-self.is * e, self.is * e / self.vtb)
                }
                _ => match self.reverse {
                    ReverseCurrent::Cubic => {
                        let a = 3.0 * vte / (v * std::f64::consts::E);
                        let a3 = a * a * a;
                        (-self.is * (1.0 + a3), self.is * 3.0 * a3 / v)
                    }
                    ReverseCurrent::Saturated => (-self.is, 0.0),
                },
            }
        }
    }

    /// The current through the junction, `i_D(v) + GMIN·v`, and its derivative.
    #[must_use]
    pub fn junction_current(&self, v: f64) -> (f64, f64) {
        let (i, g) = self.shockley(v);
        (i + self.gmin * v, g + self.gmin)
    }

    /// `∫₀^v i_D(u) du` (without `GMIN`), in closed form region by region.
    #[must_use]
    pub fn shockley_integral(&self, v: f64) -> f64 {
        let (is, vte) = (self.is, self.vte);
        if is == 0.0 {
            return 0.0;
        }
        let v3 = -3.0 * vte;
        let forward = |v: f64| is * vte * exp_m1_minus_x(v / vte);
        if v >= v3 {
            return forward(v);
        }
        let c = 3.0 * vte / std::f64::consts::E;
        let c3 = match self.reverse {
            ReverseCurrent::Cubic => c * c * c,
            ReverseCurrent::Saturated => 0.0,
        };
        let reverse = |v: f64| {
            forward(v3) - is * (v - v3) + 0.5 * is * c3 * (1.0 / (v * v) - 1.0 / (v3 * v3))
        };
        match self.bv {
            Some(bv) if v < -bv => {
                reverse(-bv) + is * self.vtb * ((-(bv + v) / self.vtb).exp() - 1.0)
            }
            _ => reverse(v),
        }
    }

    /// The depletion charge `Q_d(v)` (bottom plus sidewall) and capacitance `dQ_d/dv`
    /// (`dioload.c`).
    #[must_use]
    pub fn depletion_charge(&self, v: f64) -> (f64, f64) {
        let (qb, cb) = self.bottom.charge(v);
        let (qs, cs) = self.sidewall.charge(v);
        (qb + qs, cb + cs)
    }

    /// `∫₀^v Q_d(u) du`, in closed form.
    #[must_use]
    pub fn depletion_integral(&self, v: f64) -> f64 {
        self.bottom.integral(v) + self.sidewall.integral(v)
    }

    /// The junction charge `Q_j(v)` (depletion plus diffusion `TT·(i_D + GMIN·v)`) and the
    /// junction capacitance `dQ_j/dv`.
    #[must_use]
    pub fn junction_charge(&self, v: f64) -> (f64, f64) {
        let (qd, cd) = self.depletion_charge(v);
        if self.tt == 0.0 {
            return (qd, cd);
        }
        let (i, g) = self.junction_current(v);
        (qd + self.tt * i, cd + self.tt * g)
    }

    /// The co-energy `L(v) = ∫₀^v Q_j(u) du` (the Lagrangian).
    #[must_use]
    pub fn co_energy(&self, v: f64) -> f64 {
        let diffusion = if self.tt == 0.0 {
            0.0
        } else {
            self.tt * (self.shockley_integral(v) + 0.5 * self.gmin * v * v)
        };
        self.depletion_integral(v) + diffusion
    }

    /// The stored energy `v·Q_j(v) − L(v) = ∫₀^v u dQ_j(u)` (≥ 0).
    #[must_use]
    pub fn stored_energy(&self, v: f64) -> f64 {
        v * self.junction_charge(v).0 - self.co_energy(v)
    }

    /// The power dissipated at branch current `i` and junction voltage `v`:
    /// `R_S i² + v·(i_D(v) + GMIN·v)` (≥ 0).
    #[must_use]
    pub fn dissipation(&self, i: f64, v: f64) -> f64 {
        self.rs * i * i + v * self.junction_current(v).0
    }

    /// The power a solved step leaves in the diode: `i·(v + R_S i) − v·i_c`, the power into its
    /// terminals (branch current `i` times terminal voltage `v + R_S i`, `v` the junction voltage)
    /// less the junction's charging power `v·i_c` (`i_c = ΔQ_j/h`, 0 without junction charge).
    /// It equals [`Diode::dissipation`] when the device relation `i − i_c = i_D(v) + GMIN·v`
    /// holds; taken from the solved current rather than from the device relation, it is negative
    /// when a solution's current opposes its junction voltage, which `dissipation` (≥ 0 whatever
    /// its arguments) cannot show.
    #[must_use]
    pub fn terminal_dissipation(&self, i: f64, v: f64, i_c: f64) -> f64 {
        i * (v + self.rs * i) - v * i_c
    }

    /// The junction voltage ngspice's `DEVpnjlim` lets an iteration move to from `old` towards
    /// `new` (the mirrored form below the breakdown knee), with one change: the forward step
    /// `V_te(2 + ln(Δ/V_te − 2))` of `DEVpnjlim`, which steps backwards for
    /// `Δ/V_te < 2 + e⁻²`, is `V_te(2 + ln(Δ/V_te − 1))` here: equal to the requested step at
    /// `Δ = 2V_te`, logarithmic beyond, never backwards and never past the Newton step.
    #[must_use]
    pub fn limit_junction_voltage(&self, new: f64, old: f64) -> f64 {
        if let Some(bv) = self.bv
            && new < (-bv + 10.0 * self.vtb).min(0.0)
        {
            let limited = pnjlim(-(new + bv), -(old + bv), self.vtb, self.vcrit);
            return -(limited + bv);
        }
        pnjlim(new, old, self.vte, self.vcrit)
    }

    /// This part as a subsystem named `name` with port `i` (anode `+` to cathode `−`).
    pub fn subsystem(self, name: impl Into<String>) -> Subsystem {
        Subsystem::new(name, self).with_port("i", 0)
    }
}

/// `eˣ − 1 − x` without cancellation.
pub(crate) fn exp_m1_minus_x(x: f64) -> f64 {
    if x.abs() < SERIES {
        let mut term = x * x / 2.0;
        let mut sum = term;
        for j in 3..9 {
            term *= x / f64::from(j);
            sum += term;
        }
        sum
    } else {
        x.exp_m1() - x
    }
}

/// `DEVpnjlim` (ngspice `devsup.c`) with the forward step made monotone (see
/// [`Diode::limit_junction_voltage`]).
pub(crate) fn pnjlim(new: f64, old: f64, vt: f64, vcrit: f64) -> f64 {
    if new > vcrit && (new - old).abs() > 2.0 * vt {
        if old > 0.0 {
            let arg = (new - old) / vt;
            old + (vt * (2.0 + (arg.abs() - 1.0).ln())).copysign(arg)
        } else {
            vt * (new / vt).ln()
        }
    } else if new < 0.0 {
        let floor = if old > 0.0 {
            -old - 1.0
        } else {
            2.0 * old - 1.0
        };
        new.max(floor)
    } else {
        new
    }
}

/// The breakdown voltage at which the breakdown branch `−I_S e^{−(BV_eff+v)/V_tb}` carries `IBV`
/// at `v = −BV`, found as `diotemp.c` finds it (same start, fixed-point map, tolerance and
/// iteration limit, so the knee sits where ngspice puts it).
fn breakdown_knee(bv: f64, ibv: f64, is: f64, vt: f64, nbv: f64) -> f64 {
    if ibv < is * bv / vt {
        return bv;
    }
    let tol = BREAKDOWN_MATCH_RELTOL * ibv;
    let vtb = nbv * vt;
    let mut xbv = bv - vtb * (1.0 + ibv / is).ln();
    for _ in 0..BREAKDOWN_MATCH_ITERATIONS {
        xbv = bv - vtb * (ibv / is + 1.0 - xbv / vt).ln();
        let xcbv = is * (((bv - xbv) / vtb).exp() - 1.0 + xbv / vt);
        if (xcbv - ibv).abs() <= tol {
            break;
        }
    }
    xbv
}

fn validate(p: &DiodeParameters, celsius: f64) -> Result<(), DiodeError> {
    let fail = |parameter, value, reason| {
        Err(DiodeError {
            parameter,
            value,
            reason,
        })
    };
    let finite = [
        ("IS", p.is),
        ("N", p.n),
        ("RS", p.rs),
        ("CJO", p.cjo),
        ("VJ", p.vj),
        ("M", p.m),
        ("FC", p.fc),
        ("TT", p.tt),
        ("IBV", p.ibv),
        ("EG", p.eg),
        ("XTI", p.xti),
        ("TNOM", p.tnom),
        ("TCV", p.tcv),
        ("AREA", p.area),
        ("TEMP", celsius),
    ];
    for (name, value) in finite {
        if !value.is_finite() {
            return fail(name, value, "must be finite");
        }
    }
    if p.is < 0.0 {
        return fail("IS", p.is, "must not be negative");
    }
    if p.n <= 0.0 {
        return fail("N", p.n, "must be positive");
    }
    if let Some(nbv) = p.nbv
        && !(nbv > 0.0 && nbv.is_finite())
    {
        return fail("NBV", nbv, "must be positive");
    }
    if p.rs < 0.0 {
        return fail("RS", p.rs, "must not be negative");
    }
    if p.cjo < 0.0 {
        return fail("CJO", p.cjo, "must not be negative");
    }
    if p.vj <= 0.0 {
        return fail("VJ", p.vj, "must be positive");
    }
    if !(0.0..1.0).contains(&p.m) {
        return fail("M", p.m, "must lie in [0, 1)");
    }
    if !(0.0..1.0).contains(&p.fc) {
        return fail("FC", p.fc, "must lie in [0, 1)");
    }
    for (name, value) in [("MJSW", p.mjsw), ("FCS", p.fcs)] {
        if !(0.0..1.0).contains(&value) {
            return fail(name, value, "must lie in [0, 1)");
        }
    }
    if !(p.cjsw >= 0.0 && p.cjsw.is_finite()) {
        return fail("CJSW", p.cjsw, "must not be negative");
    }
    if !(p.vjsw > 0.0 && p.vjsw.is_finite()) {
        return fail("VJSW", p.vjsw, "must be positive");
    }
    if p.tt < 0.0 {
        return fail("TT", p.tt, "must not be negative");
    }
    if let Some(bv) = p.bv
        && !(bv > 0.0 && bv.is_finite())
    {
        return fail(
            "BV",
            bv,
            "must be positive (the magnitude of the breakdown voltage)",
        );
    }
    if p.ibv <= 0.0 {
        return fail("IBV", p.ibv, "must be positive");
    }
    if p.area <= 0.0 {
        return fail("AREA", p.area, "must be positive");
    }
    if celsius <= -ZERO_CELSIUS || p.tnom <= -ZERO_CELSIUS {
        return fail(
            "TEMP/TNOM",
            celsius.min(p.tnom),
            "must be above absolute zero",
        );
    }
    Ok(())
}

impl Model for Diode {
    fn dim(&self) -> usize {
        2
    }
    fn lagrangian(&self, _q: &[f64], v: &[f64]) -> f64 {
        if self.has_charge() {
            self.co_energy(v[1])
        } else {
            0.0
        }
    }
    fn lagrangian_gradient(&self, _q: &[f64], v: &[f64], lq: &mut [f64], lv: &mut [f64]) {
        lq.fill(0.0);
        lv[0] = 0.0;
        lv[1] = if self.has_charge() {
            self.junction_charge(v[1]).0
        } else {
            0.0
        };
    }
    fn lagrangian_hessian(&self, _q: &[f64], v: &[f64], h: &mut LagrangianHessian) {
        if self.has_charge() {
            h.vv.add(1, 1, self.junction_charge(v[1]).1);
        }
    }
    fn has_force(&self) -> bool {
        true
    }
    fn force(&self, _q: &[f64], v: &[f64], _t: f64, f: &mut [f64]) {
        f[0] = -v[1] - self.rs * v[0];
        f[1] = v[0] - self.junction_current(v[1]).0;
    }
    fn force_jacobian(&self, _q: &[f64], v: &[f64], _t: f64, j: &mut ForceJacobian) {
        // The (0, 0) entry only with a series resistance: a structural zero would let the
        // readout's structural analysis pick the branch current from the junction's KVL row.
        if self.rs != 0.0 {
            j.v.add(0, 0, -self.rs);
        }
        j.v.add(0, 1, -1.0);
        j.v.add(1, 0, 1.0);
        j.v.add(1, 1, -self.junction_current(v[1]).1);
    }
    fn is_autonomous(&self) -> bool {
        true
    }
    fn has_update_limit(&self) -> bool {
        true
    }
    fn update_fraction(&self, _q: &[f64], v: &[f64], _dq: &[f64], dv: &[f64]) -> f64 {
        let (old, step) = (v[1], dv[1]);
        if step == 0.0 {
            return 1.0;
        }
        let new = old + step;
        let limited = self.limit_junction_voltage(new, old);
        // Not limited: the whole update. `(new − old)/step` would differ from 1 by the rounding
        // of `old + step`, which for an update of a few ulps of `old` is tens of percent, and
        // Newton would keep damping an iterate already at round-off (a ladder of 50 diodes,
        // whose far junctions settle at 1e-26 updates, failed its first step that way).
        if limited == new {
            return 1.0;
        }
        let alpha = (limited - old) / step;
        // Outside (0, 1] only for unusual parameters (V_crit below zero); the update is then
        // left alone.
        if alpha > 0.0 && alpha <= 1.0 {
            alpha
        } else {
            1.0
        }
    }
    fn coordinate_name(&self, i: usize) -> String {
        ["q", "phi"][i].into()
    }
}

#[cfg(test)]
mod tests {
    //! The device on its own: the current, charge and co-energy against closed forms and
    //! quadrature written independently here, the hand-written derivatives against central
    //! differences, passivity at random states, the temperature model against SPICE's formulas,
    //! and the junction limiting.

    use super::*;
    use crate::testing::{dense, rel};

    /// A card exercising every modelled effect (depletion, diffusion, breakdown, series
    /// resistance), with ngspice-typical values.
    fn full_card() -> DiodeParameters {
        DiodeParameters {
            is: 2.52e-9,
            n: 1.752,
            rs: 0.568,
            cjo: 4e-12,
            vj: 0.75,
            m: 0.4,
            fc: 0.5,
            tt: 20e-9,
            bv: Some(100.0),
            ibv: 100e-6,
            ..DiodeParameters::default()
        }
    }

    fn at(card: &DiodeParameters, celsius: f64) -> Diode {
        Diode::at_temperature(card, celsius)
            .expect("valid card")
            .diode
    }

    /// Simpson's rule with `n` (even) panels.
    /// `∫₀^v f` by Simpson's rule in two pieces when `knee` lies strictly between 0 and `v`
    /// (where `f` has a kink or a step).
    fn simpson_across(knee: f64, v: f64, n: usize, f: impl Fn(f64) -> f64) -> f64 {
        if knee * v > 0.0 && knee.abs() < v.abs() {
            simpson(0.0, knee, n, &f) + simpson(knee, v, n, &f)
        } else {
            simpson(0.0, v, n, f)
        }
    }

    fn simpson(a: f64, b: f64, n: usize, f: impl Fn(f64) -> f64) -> f64 {
        let h = (b - a) / n as f64;
        let mut sum = f(a) + f(b);
        for j in 1..n {
            sum += f(a + j as f64 * h) * if j % 2 == 1 { 4.0 } else { 2.0 };
        }
        sum * h / 3.0
    }

    /// Forward and reverse currents are SPICE's level-1 expressions at 27 °C (written out here
    /// with `kT/q` from CODATA 2014 as ngspice uses it), the regions join with continuous value
    /// and slope at `−3 V_te`, and the breakdown branch carries `IBV` at `−BV` to the accuracy
    /// ngspice matches it to (`RELTOL` = 1e-3).
    ///
    /// Mutations: `vte` from `n·vt` to `vt`, or the temperature to 300 K: the forward relation
    /// fails (1e-2 and 7e-3 relative); the reverse cube `a³` → `a²`: the reverse relation fails.
    #[test]
    fn current_matches_spice_level_one() {
        let card = full_card();
        let d = at(&card, 27.0);
        let vt = 1.380_648_52e-23 * 300.15 / 1.602_176_620_8e-19;
        assert!(rel(d.thermal_voltage(), vt, 1.0) < 1e-15);
        assert!(rel(vt, 0.025_864_917, 1.0) < 1e-8, "{vt}");
        let vte = card.n * vt;
        for v in [-3.0 * vte, -0.01, 0.3, 0.7, 1.2] {
            let expect = card.is * ((v / vte).exp() - 1.0);
            let (i, _) = d.shockley(v);
            assert!(
                rel(i, expect, 1e-30) < 1e-12,
                "v = {v}: {i:e} vs {expect:e}"
            );
        }
        // Near zero `e^x − 1` cancels; its series is exact there.
        for v in [0.0, 1e-9, -1e-7] {
            let x = v / vte;
            let expect = card.is * (x + x * x / 2.0 + x * x * x / 6.0);
            let (i, _) = d.shockley(v);
            assert!(
                rel(i, expect, 1e-300) < 1e-14,
                "v = {v}: {i:e} vs {expect:e}"
            );
        }
        for v in [-3.0 * vte - 1e-9, -0.5, -10.0, -99.0] {
            let expect = -card.is * (1.0 + (3.0 * vte / (v * std::f64::consts::E)).powi(3));
            let (i, _) = d.shockley(v);
            assert!(
                rel(i, expect, 1e-30) < 1e-14,
                "v = {v}: {i:e} vs {expect:e}"
            );
        }
        let v3 = -3.0 * vte;
        let (below, gb) = d.shockley(v3 * (1.0 + 1e-12));
        let (above, ga) = d.shockley(v3);
        assert!(rel(below, above, 1e-30) < 1e-11 && rel(gb, ga, 1e-30) < 1e-9);
        // ngspice matches the knee `BV_eff` by `I_S (e^{(BV − BV_eff)/V_tb} − 1 + BV_eff/V_t) = IBV`
        // (diotemp.c) to RELTOL, so the current at −BV is IBV less that linear term.
        let bv = card.bv.expect("bv");
        let knee = d.breakdown_voltage().expect("knee");
        let matched = d.saturation_current() * (((bv - knee) / vte).exp() - 1.0 + knee / vt);
        assert!(
            rel(matched, card.ibv, 1e-30) < BREAKDOWN_MATCH_RELTOL,
            "{matched:e}"
        );
        assert!(knee < bv && knee > bv - 1.0, "{knee}");
        // The breakdown branch is −I_S e^{−(BV_eff + v)/V_tb}.
        for v in [-knee - 1e-3, -bv, -bv - 0.1] {
            let expect = -d.saturation_current() * (-(knee + v) / vte).exp();
            assert!(rel(d.shockley(v).0, expect, 1e-30) < 1e-13, "v = {v}");
        }
    }

    /// The junction current against ngspice 39's operating points of a voltage source across the
    /// diode (`-i(V1)`, 12 digits, GMIN included), at 27 °C and at 100 °C with `TNOM = 20`,
    /// `NBV = 2`: every region, the breakdown knee match and the temperature adjustment. Reproduce
    /// with a netlist `V1 a 0 DC 0`, `D1 a 0 dmod`, the card below, `.temp 100`, and a
    /// `.control` loop `alter V1 dc = $vv`, `op`, `print -i(V1)` under `set numdgt=12`.
    ///
    /// Mutation: the temperature exponent `XTI/N` → `XTI`: the 100 °C currents fail (factor 2).
    #[test]
    fn agrees_with_ngspice_operating_points() {
        let card = full_card();
        let table_27: [(f64, f64); 4] = [
            (-100.0, -9.030_644_243_05e-5),
            (-99.4, -2.619_399_999_68e-9),
            (-0.5, -2.517_978_224_51e-9),
            (0.6, 1.418_071_135_934e-3),
        ];
        let hot_card = DiodeParameters {
            nbv: Some(2.0),
            tnom: 20.0,
            ..card
        };
        let table_100: [(f64, f64); 7] = [
            (-120.0, -9.471_802_212_18e128),
            (-100.05, -1.793_408_598_38e-6),
            (-99.4, -8.242_450_048_79e-7),
            (-0.5, -8.225_614_121_50e-7),
            (-0.1, -6.844_731_463_47e-7),
            (0.3, 1.684_858_197_933e-4),
            (0.6, 3.478_169_984_698e-2),
        ];
        for (d, table) in [
            (at(&card, 27.0), &table_27[..]),
            (at(&hot_card, 100.0), &table_100[..]),
        ] {
            for &(v, ngspice) in table {
                let (i, _) = d.junction_current(v);
                // ngspice prints 12 significant digits; its breakdown knee is matched to
                // RELTOL, which both codes do identically.
                assert!(
                    rel(i, ngspice, 1e-300) < 1e-10,
                    "v = {v}: {i:e} vs ngspice {ngspice:e}"
                );
            }
        }
    }

    /// Central differences (step 1e-6 relative) against every hand-written derivative of the
    /// current, the charge and the co-energy, away from region boundaries, to 1e-7 relative;
    /// and the model's Hessian and force Jacobian are these functions.
    ///
    /// Mutations: the depletion capacitance exponent `−M` → `−M − 0.01`, or the breakdown slope
    /// divided by `V_te` instead of `V_tb` with `NBV ≠ N`: fails (1e-2 relative).
    #[test]
    fn hand_written_derivatives() {
        let card = DiodeParameters {
            nbv: Some(2.0),
            ..full_card()
        };
        let d = at(&card, 60.0);
        let knee = d.breakdown_voltage().expect("knee");
        // An absolute step of 1 µV: truncation (e/V_t)² ≈ 1e-9 relative; the round-off of the
        // difference, 4ε|f|/e, is allowed on top (it dominates where GMIN·v is far below I_S).
        let e = 1e-6;
        let fd = |f: &dyn Fn(f64) -> f64, v: f64| (f(v + e) - f(v - e)) / (2.0 * e);
        let agrees = |exact: f64, f: &dyn Fn(f64) -> f64, v: f64| {
            let roundoff = 4.0 * f64::EPSILON * f(v).abs() / e;
            (exact - fd(f, v)).abs() <= 1e-7 * exact.abs() + roundoff
        };
        for v in [
            -knee - 0.3,
            -knee + 0.5,
            -20.0,
            -0.5,
            -0.02,
            0.01,
            0.2,
            0.374,
            0.376,
            0.6,
            0.9,
        ] {
            let current = |u: f64| d.junction_current(u).0;
            let charge = |u: f64| d.junction_charge(u).0;
            let co_energy = |u: f64| d.co_energy(u);
            let (_, g) = d.junction_current(v);
            assert!(
                agrees(g, &current, v),
                "di/dv at {v}: {g:e} vs {:e}",
                fd(&current, v)
            );
            let (q, c) = d.junction_charge(v);
            assert!(
                agrees(c, &charge, v),
                "dQ/dv at {v}: {c:e} vs {:e}",
                fd(&charge, v)
            );
            assert!(
                agrees(q, &co_energy, v),
                "dL/dv at {v}: {q:e} vs {:e}",
                fd(&co_energy, v)
            );
            let i = 0.37e-3;
            let mut f = [0.0; 2];
            d.force(&[0.0, 0.0], &[i, v], 0.0, &mut f);
            assert_eq!(
                f,
                [-v - d.series_resistance() * i, i - d.junction_current(v).0]
            );
            let mut jac = ForceJacobian::default();
            jac.begin();
            d.force_jacobian(&[0.0, 0.0], &[i, v], 0.0, &mut jac);
            let jv = dense(&jac.v, 2, 2);
            assert_eq!(jv, [[-d.series_resistance(), -1.0], [1.0, -g]]);
            let mut h = LagrangianHessian::default();
            h.begin();
            d.lagrangian_hessian(&[0.0, 0.0], &[i, v], &mut h);
            assert_eq!(dense(&h.vv, 2, 2), [[0.0, 0.0], [0.0, c]]);
            let (mut lq, mut lv) = ([1.0; 2], [1.0; 2]);
            d.lagrangian_gradient(&[0.0, 0.0], &[i, v], &mut lq, &mut lv);
            assert_eq!((lq, lv), ([0.0; 2], [0.0, q]));
            assert_eq!(d.lagrangian(&[0.0, 0.0], &[i, v]), d.co_energy(v));
        }
    }

    /// A MOSFET junction's reverse current is `−I_S` below `−3V_t` (`mos1load.c`), where the
    /// diode's approaches it as a cubic; its integral (the co-energy of a diffusion charge) is
    /// the integral of that current.
    #[test]
    fn saturated_reverse_current() {
        let card = DiodeParameters {
            reverse: ReverseCurrent::Saturated,
            tt: 1e-9,
            ..DiodeParameters::new(1e-12, 1.0)
        };
        let d = at(&card, 27.0);
        let vt = d.thermal_voltage();
        assert_eq!(d.shockley(-3.5 * vt), (-1e-12, 0.0));
        let cubic = at(&DiodeParameters::new(1e-12, 1.0), 27.0);
        assert!(cubic.shockley(-3.5 * vt).0 > -1e-12);
        for v in [-0.5, -3.5 * vt, -0.01, 0.3] {
            // Across the step at −3V_t in two pieces, the second from the value below it.
            let knee = -3.0 * vt;
            let exact = if v < knee {
                simpson(0.0, knee, 20000, |u| d.shockley(u).0)
                    + simpson(knee, v, 20000, |u| {
                        d.shockley(u.min(knee * (1.0 + 1e-12))).0
                    })
            } else {
                simpson(0.0, v, 20000, |u| d.shockley(u).0)
            };
            let integral = d.shockley_integral(v);
            assert!(
                rel(integral, exact, 1e-30) < 1e-7,
                "{v}: {integral:e} vs {exact:e}"
            );
        }
    }

    /// The depletion charge is `∫₀^v CJO (1 − u/VJ)^{−M} du` below `FC·VJ` and continues with
    /// the linear capacitance `CJO/F2 (F3 + M u/VJ)` above (both integrated here by Simpson's
    /// rule from the capacitance formulas alone); the co-energy is `∫₀^v Q_j`, and the stored
    /// energy `v Q_j − L = ∫₀^v u dQ_j` is non-negative.
    ///
    /// Mutation: `F3 = 1 − FC(1 + M)` → `1 − FC·M`: the charge above the knee fails (3e-2).
    #[test]
    fn junction_charge_and_energy_against_quadrature() {
        let card = full_card();
        let d = at(&card, 27.0);
        let (cjo, vj, m, fc) = (card.cjo, card.vj, card.m, card.fc);
        let capacitance = |u: f64| {
            if u < fc * vj {
                cjo * (1.0 - u / vj).powf(-m)
            } else {
                let f2 = (1.0 - fc).powf(1.0 + m);
                let f3 = 1.0 - fc * (1.0 + m);
                cjo / f2 * (f3 + m * u / vj)
            }
        };
        for v in [-50.0, -2.0, -0.3, 1e-6, 0.2, 0.375, 0.5, 0.8] {
            let knee = fc * vj;
            let q_exact = simpson_across(knee, v, 4000, capacitance);
            let (q, _) = d.depletion_charge(v);
            assert!(
                rel(q, q_exact, 1e-30) < 1e-9,
                "Q_d({v}) = {q:e} vs {q_exact:e}"
            );
            let l_exact = simpson(0.0, v, 4000, |u| d.junction_charge(u).0);
            assert!(
                rel(d.co_energy(v), l_exact, 1e-30) < 1e-8,
                "L({v}) = {:e} vs {l_exact:e}",
                d.co_energy(v)
            );
            let e_exact = simpson(0.0, v, 4000, |u| u * d.junction_charge(u).1);
            let e = d.stored_energy(v);
            assert!(e >= 0.0, "{v}: {e}");
            assert!(
                rel(e, e_exact, 1e-30) < 1e-8,
                "E({v}) = {e:e} vs {e_exact:e}"
            );
        }
        // A sidewall term of its own potential, grading and knee adds its charge and co-energy.
        let with_sidewall = DiodeParameters {
            cjsw: 1.5e-12,
            vjsw: 0.6,
            mjsw: 0.3,
            fcs: 0.4,
            ..card
        };
        let ds = at(&with_sidewall, 27.0);
        let sidewall = |u: f64| {
            let (c, vj, m, fc) = (1.5e-12, 0.6, 0.3, 0.4);
            if u < fc * vj {
                c * (1.0 - u / vj).powf(-m)
            } else {
                c / (1.0 - fc).powf(1.0 + m) * (1.0 - fc * (1.0 + m) + m * u / vj)
            }
        };
        for v in [-20.0, -0.5, 0.1, 0.24, 0.3, 0.7] {
            let knee = 0.4 * 0.6;
            let q_side = simpson_across(knee, v, 4000, sidewall);
            let q = ds.depletion_charge(v).0 - d.depletion_charge(v).0;
            assert!(
                rel(q, q_side, 1e-30) < 1e-9,
                "sidewall Q({v}) = {q:e} vs {q_side:e}"
            );
            let l_exact = simpson(0.0, v, 4000, |u| ds.junction_charge(u).0);
            assert!(
                rel(ds.co_energy(v), l_exact, 1e-30) < 1e-8,
                "sidewall L({v})"
            );
        }
        // Small voltages: the series branches give ½ C₀ v² without cancellation.
        for v in [1e-9, -1e-7] {
            let e = d.stored_energy(v);
            let c0 = d.junction_charge(0.0).1;
            assert!(rel(e, 0.5 * c0 * v * v, 1e-300) < 1e-6, "{e:e}");
        }
    }

    /// The power of the forces, `f_q q̇ + f_φ φ̇`, equals minus the dissipation
    /// `R_S i² + v (i_D + GMIN v)`, which is non-negative at every state (the diode never
    /// produces energy): 10⁵ pseudo-random states over ±600 V and ±10 A, three cards.
    ///
    /// Mutation: the reverse-region current with its sign flipped (`+I_S(1 + a³)`): the
    /// dissipation goes negative.
    #[test]
    fn passive_at_random_states() {
        let mut seed: u64 = 0x9e37_79b9_7f4a_7c15;
        let mut uniform = move || {
            seed ^= seed << 13;
            seed ^= seed >> 7;
            seed ^= seed << 17;
            (seed >> 11) as f64 / (1u64 << 53) as f64
        };
        let cards = [
            full_card(),
            DiodeParameters::new(1e-16, 1.0),
            DiodeParameters {
                bv: Some(5.1),
                ibv: 1e-2,
                rs: 2.0,
                ..DiodeParameters::new(1e-12, 1.9)
            },
        ];
        for card in &cards {
            let d = at(card, 27.0);
            for _ in 0..100_000 {
                let v = (uniform() - 0.75) * 2400.0 * uniform().powi(8);
                let i = (uniform() - 0.5) * 20.0 * uniform().powi(6);
                let dissipation = d.dissipation(i, v);
                assert!(dissipation >= 0.0, "v = {v}, i = {i}: {dissipation:e}");
                if dissipation.is_infinite() {
                    // The exponential overflowed (far forward or deep in breakdown): +∞, not NaN.
                    continue;
                }
                let mut f = [0.0; 2];
                d.force(&[0.0, 0.0], &[i, v], 0.0, &mut f);
                let power = f[0] * i + f[1] * v;
                // Round-off of the two cancelling products v·i.
                let roundoff = 4.0 * f64::EPSILON * (v * i).abs();
                assert!(
                    (power + dissipation).abs() <= roundoff + 1e-15 * dissipation,
                    "v = {v}, i = {i}: {power:e} vs {dissipation:e}"
                );
            }
        }
    }

    /// At `T = TNOM` the card is used as given; elsewhere `IS` follows SPICE's
    /// `IS (T/TNOM)^{XTI/N} exp((T/TNOM − 1) EG/(N kT/q))` and `VJ`, `CJO` the `diotemp.c`
    /// formulas (evaluated here from the textbook form `VJ(T) = VJ T/TNOM − 3 kT/q ln(T/TNOM)
    /// − EG(T)·T/TNOM + EG(T)` with `EG(T) = 1.16 − 7.02e-4 T²/(T + 1108)`), and
    /// `CJO(T) = CJO (1 + M (4e-4 (T − TNOM) − (VJ(T) − VJ)/VJ))`.
    ///
    /// Mutation: `XTI/N` → `XTI`: `IS(100 °C)` fails (factor 1.4).
    #[test]
    fn temperature_scaling() {
        let card = DiodeParameters {
            tnom: 27.0,
            ..full_card()
        };
        let d = at(&card, 27.0);
        assert!(rel(d.saturation_current(), card.is, 1e-300) < 1e-15);
        assert!(
            rel(d.bottom.vj, card.vj, 1e-300) < 1e-15
                && rel(d.bottom.cj0, card.cjo, 1e-300) < 1e-15
        );
        let hot = at(&card, 100.0);
        let (t, tn): (f64, f64) = (373.15, 300.15);
        let vt = 1.380_648_52e-23 * t / 1.602_176_620_8e-19;
        let is = card.is
            * (t / tn).powf(card.xti / card.n)
            * ((t / tn - 1.0) * card.eg / (card.n * vt)).exp();
        assert!(rel(hot.saturation_current(), is, 1e-300) < 1e-12);
        let eg = |t: f64| 1.16 - 7.02e-4 * t * t / (t + 1108.0);
        let vj = card.vj * t / tn - 3.0 * vt * (t / tn).ln() - eg(tn) * t / tn + eg(t);
        // ngspice writes EG(300.15 K) = 1.115087698… as 1.1150877, which moves its VJ(T) and
        // CJO(T) by about 4e-8 relative from the textbook form.
        let ngspice_constant = 2e-7;
        assert!(
            rel(hot.bottom.vj, vj, 1e-300) < ngspice_constant,
            "{} vs {vj}",
            hot.bottom.vj
        );
        let cj = card.cjo * (1.0 + card.m * (4e-4 * (t - tn) - (vj - card.vj) / card.vj));
        assert!(
            rel(hot.bottom.cj0, cj, 1e-300) < ngspice_constant,
            "{} vs {cj}",
            hot.bottom.cj0
        );
        // The same card measured at 50 °C and used at 50 °C is unchanged.
        let warm = DiodeParameters { tnom: 50.0, ..card };
        let d50 = at(&warm, 50.0);
        assert!(rel(d50.saturation_current(), card.is, 1e-300) < 1e-15);
        assert!(rel(d50.bottom.vj, card.vj, 1e-300) < 1e-13);
    }

    /// The junction limit follows `DEVpnjlim`: a forward step from reverse bias lands at
    /// `V_te ln(v/V_te)`, a forward step from forward bias grows logarithmically and never
    /// backwards or past the requested point, reverse steps at most double (plus 1 V) per
    /// iteration, small steps pass unchanged; the update fraction is the limited share.
    #[test]
    fn junction_limiting() {
        let d = at(&DiodeParameters::new(1e-14, 1.0), 27.0);
        let vte = d.thermal_voltage();
        let vcrit = d.critical_voltage();
        assert!((0.7..0.8).contains(&vcrit), "{vcrit}");
        assert_eq!(d.limit_junction_voltage(5.0, -1.0), vte * (5.0 / vte).ln());
        assert_eq!(d.limit_junction_voltage(0.6, 0.59), 0.6);
        assert_eq!(d.limit_junction_voltage(-500.0, 0.0), -1.0);
        assert_eq!(d.limit_junction_voltage(-500.0, -3.0), -7.0);
        assert_eq!(d.limit_junction_voltage(-500.0, 0.5), -1.5);
        for step in [2.000_001, 2.1, 3.0, 10.0, 1e3, 1e6] {
            let new = 0.7 + step * vte;
            let limited = d.limit_junction_voltage(new, 0.7);
            assert!(limited > 0.7 && limited <= new, "{step}: {limited}");
        }
        let alpha_at = |old: f64, new: f64| {
            d.update_fraction(&[0.0; 2], &[0.0, old], &[0.0; 2], &[0.0, new - old])
        };
        assert_eq!(alpha_at(0.0, -500.0), 1.0 / 500.0);
        assert_eq!(alpha_at(0.6, 0.61), 1.0);
        // An update of 1.3 ulps is not limited: the whole of it, although `(old + step) − old`
        // rounds to 1 ulp (a fraction 0.77, which kept Newton damping an iterate at round-off).
        let step = 1.3 * f64::EPSILON * 0.25;
        assert_ne!((0.3 + step) - 0.3, step);
        assert_eq!(
            d.update_fraction(&[0.0; 2], &[0.0, 0.3], &[0.0; 2], &[0.0, step]),
            1.0
        );
        // Below the breakdown knee the mirrored limit applies.
        let z = at(
            &DiodeParameters {
                bv: Some(5.0),
                ..DiodeParameters::new(1e-14, 1.0)
            },
            27.0,
        );
        let knee = z.breakdown_voltage().expect("knee");
        let limited = z.limit_junction_voltage(-50.0, -knee);
        assert!(limited > -knee - 0.5 && limited < -knee, "{limited}");
    }

    /// Invalid cards are typed errors naming the parameter; ngspice's limits are warnings.
    #[test]
    fn invalid_cards() {
        let bad = |p: DiodeParameters| Diode::at_temperature(&p, 27.0).unwrap_err().parameter;
        assert_eq!(bad(DiodeParameters::new(1e-14, 0.0)), "N");
        assert_eq!(
            bad(DiodeParameters {
                fc: 1.0,
                ..full_card()
            }),
            "FC"
        );
        assert_eq!(
            bad(DiodeParameters {
                cjo: -1e-12,
                ..full_card()
            }),
            "CJO"
        );
        assert_eq!(
            bad(DiodeParameters {
                bv: Some(-5.0),
                ..full_card()
            }),
            "BV"
        );
        let limited = Diode::at_temperature(
            &DiodeParameters {
                vj: 3.0,
                ..full_card()
            },
            27.0,
        )
        .expect("limited, not refused");
        assert_eq!(limited.warnings.len(), 1, "{:?}", limited.warnings);
        assert_eq!(limited.diode.bottom.vj, 2.0);
    }
}
