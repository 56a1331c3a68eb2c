//! Bipolar junction transistor, SPICE Gummel–Poon as ngspice-39's `bjt` (level 1) computes it.
//!
//! A BJT is a core ([`BjtCore`]: the transport and base currents between the inner collector,
//! base and emitter, and the base–emitter and base–collector junction charges), optional series
//! resistances `RB`, `RC`, `RE`, and a substrate junction (`GMIN` and the depletion charge `CJS`)
//! between the substrate node and the inner collector (vertical device, an NPN's default) or the
//! inner base (lateral, a PNP's default). [`Bjt::at_temperature`] computes them from a model card
//! and an instance at the circuit temperature; a netlist places them.
//!
//! **What fits the variational formulation.** Each junction charge must be a function of its own
//! junction voltage, so that the pair is the gradient of a co-energy. The depletion charges
//! (`CJE`, `CJC`, `CJS`) and the diffusion charges `TF·I_BE` and `TR·I_BC` are. ngspice divides
//! the forward diffusion charge by the base charge `q_b(V_BE, V_BC)` (for `V_BE > 0`), and with
//! `VAF` or `IKR` that makes `∂Q_BE/∂V_BC ≠ 0 = ∂Q_BC/∂V_BE`: no function of the voltages has
//! these charges as its gradient (the integrability condition fails), as for the MOSFET's Meyer
//! capacitances. A card with `TF > 0` and `VAF`, `VAR`, `IKF` or `IKR` is refused: with `VAF`
//! or `IKR` for that reason, with `VAR` or `IKF` alone (where the charge is a function of
//! `V_BE` but its co-energy has no closed form) because it is not modelled. The bias dependence
//! of `TF` (`XTF`, `VTF`, `ITF`), excess phase (`PTF`), the current-dependent base resistance
//! (`IRB`, `RBM`), a base–collector capacitance split by `XCJC < 1` across an `RB`, and the
//! substrate diode current `ISS` are not modelled and are refused by the netlist.
//!
//! Equations: `bjtload.c` (currents, charges, limiting), `bjttemp.c` (temperature, `TLEV =
//! TLEVC = 0`), `bjtsetup.c` (defaults); constants as in [`crate::Diode`].

use dirac_core::{ForceJacobian, LagrangianHessian, Model};
use dirac_graph::Subsystem;
use thiserror::Error;

use crate::diode::{
    BOLTZMANN, CHARGE, Depletion, K_OVER_Q, REFTEMP, ZERO_CELSIUS, exp_m1_minus_x, pnjlim,
};
use crate::{Diode, DiodeParameters, ReverseCurrent};

/// ngspice-39's limit on the grading coefficients `MJE`, `MJC`, `MJS` (`bjttemp.c`).
const GRADING_MAX: f64 = 0.999;

/// NPN or PNP (ngspice's `type`, +1 or −1).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum BjtPolarity {
    /// `NPN`.
    Npn,
    /// `PNP`.
    Pnp,
}

impl BjtPolarity {
    /// +1 for NPN, −1 for PNP.
    #[must_use]
    pub fn sign(self) -> f64 {
        match self {
            Self::Npn => 1.0,
            Self::Pnp => -1.0,
        }
    }
}

/// A Gummel–Poon model card (`.model NAME NPN|PNP (…)`), ngspice's names, SI units,
/// temperatures in °C, with ngspice's defaults. `VAF`, `VAR`, `IKF`, `IKR` of 0 mean infinite,
/// as in ngspice.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct BjtParameters {
    /// `NPN` or `PNP`.
    pub polarity: BjtPolarity,
    /// `SUBS`: the substrate junction sits at the collector (`true`, vertical) or at the base
    /// (lateral); ngspice's default is vertical for NPN, lateral for PNP.
    pub vertical: bool,
    /// `IS`: transport saturation current (A), default 1e-16.
    pub is: f64,
    /// `BF`: ideal forward beta, default 100.
    pub bf: f64,
    /// `NF`: forward emission coefficient, default 1.
    pub nf: f64,
    /// `VAF`: forward Early voltage (V), default 0 (infinite).
    pub vaf: f64,
    /// `IKF`: forward high-injection knee current (A), default 0 (infinite).
    pub ikf: f64,
    /// `ISE`: base–emitter leakage saturation current (A), default 0.
    pub ise: f64,
    /// `NE`: base–emitter leakage emission coefficient, default 1.5.
    pub ne: f64,
    /// `BR`: ideal reverse beta, default 1.
    pub br: f64,
    /// `NR`: reverse emission coefficient, default 1.
    pub nr: f64,
    /// `VAR`: reverse Early voltage (V), default 0 (infinite).
    pub var: f64,
    /// `IKR`: reverse high-injection knee current (A), default 0 (infinite).
    pub ikr: f64,
    /// `ISC`: base–collector leakage saturation current (A), default 0.
    pub isc: f64,
    /// `NC`: base–collector leakage emission coefficient, default 2.
    pub nc: f64,
    /// `RB`, `RC`, `RE`: base, collector and emitter resistances (Ω), default 0.
    pub rb: f64,
    /// See [`BjtParameters::rb`].
    pub rc: f64,
    /// See [`BjtParameters::rb`].
    pub re: f64,
    /// `CJE`: base–emitter zero-bias depletion capacitance (F), default 0.
    pub cje: f64,
    /// `VJE`: base–emitter built-in potential (V), default 0.75.
    pub vje: f64,
    /// `MJE`: base–emitter grading coefficient, default 0.33.
    pub mje: f64,
    /// `CJC`: base–collector zero-bias depletion capacitance (F), default 0.
    pub cjc: f64,
    /// `VJC`: base–collector built-in potential (V), default 0.75.
    pub vjc: f64,
    /// `MJC`: base–collector grading coefficient, default 0.33.
    pub mjc: f64,
    /// `XCJC`: fraction of `CJC` at the inner base, default 1.
    pub xcjc: f64,
    /// `CJS`: substrate zero-bias depletion capacitance (F), default 0.
    pub cjs: f64,
    /// `VJS`: substrate junction potential (V), default 0.75.
    pub vjs: f64,
    /// `MJS`: substrate grading coefficient, default 0.
    pub mjs: f64,
    /// `TF`: ideal forward transit time (s), default 0.
    pub tf: f64,
    /// `TR`: ideal reverse transit time (s), default 0.
    pub tr: f64,
    /// `FC`: forward-bias depletion capacitance coefficient, default 0.5 (ngspice limits it to
    /// 0.9999).
    pub fc: f64,
    /// `EG`: band gap for the temperature dependence of `IS` (eV), default 1.11.
    pub eg: f64,
    /// `XTI`: temperature exponent of `IS`, default 3.
    pub xti: f64,
    /// `XTB`: forward and reverse beta temperature exponent, default 0.
    pub xtb: f64,
    /// `TNOM`: temperature at which the parameters were measured (°C), default 27.
    pub tnom: f64,
}

impl BjtParameters {
    /// ngspice's defaults for a card of `polarity`.
    #[must_use]
    pub fn new(polarity: BjtPolarity) -> Self {
        Self {
            polarity,
            vertical: polarity == BjtPolarity::Npn,
            is: 1e-16,
            bf: 100.0,
            nf: 1.0,
            vaf: 0.0,
            ikf: 0.0,
            ise: 0.0,
            ne: 1.5,
            br: 1.0,
            nr: 1.0,
            var: 0.0,
            ikr: 0.0,
            isc: 0.0,
            nc: 2.0,
            rb: 0.0,
            rc: 0.0,
            re: 0.0,
            cje: 0.0,
            vje: 0.75,
            mje: 0.33,
            cjc: 0.0,
            vjc: 0.75,
            mjc: 0.33,
            xcjc: 1.0,
            cjs: 0.0,
            vjs: 0.75,
            mjs: 0.0,
            tf: 0.0,
            tr: 0.0,
            fc: 0.5,
            eg: 1.11,
            xti: 3.0,
            xtb: 0.0,
            tnom: 27.0,
        }
    }
}

/// A `Q` card's instance parameters, with ngspice's defaults.
///
/// As ngspice-39 scales them: `AREA` multiplies `IS`, `ISE`, `CJE` and divides `IKF`, `IKR`,
/// `RB`, `RC`, `RE`; the base area (`AREAB` of a vertical device, `AREAC` of a lateral one)
/// multiplies `ISC`, `CJC` and, on top of `AREA`, the saturation current of the base–collector
/// diode (so that current scales as `AREA²` when only `AREA` is given, as ngspice-39's
/// `bjttemp.c` computes it); the other area multiplies `CJS`.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct BjtInstance {
    /// `AREA`: emitter area factor, default 1.
    pub area: f64,
    /// `AREAB`: base area factor (ngspice's default: `AREA`).
    pub areab: f64,
    /// `AREAC`: collector area factor (ngspice's default: `AREA`).
    pub areac: f64,
    /// `M`: devices in parallel, default 1.
    pub m: f64,
}

impl Default for BjtInstance {
    fn default() -> Self {
        Self {
            area: 1.0,
            areab: 1.0,
            areac: 1.0,
            m: 1.0,
        }
    }
}

/// Why a BJT cannot be built.
#[derive(Debug, Clone, PartialEq, Error)]
#[error("{parameter} = {value}: {reason}")]
pub struct BjtError {
    /// The parameter's SPICE name.
    pub parameter: &'static str,
    /// Its value.
    pub value: f64,
    /// What is wrong with it.
    pub reason: &'static str,
}

/// The parts of one BJT at a temperature: what a netlist places between its nodes.
#[derive(Debug, Clone, PartialEq)]
pub struct Bjt {
    /// The currents and junction charges between the inner collector, base and emitter.
    pub core: BjtCore,
    /// Base, collector and emitter series resistances (Ω), already divided by `AREA·M`; zero
    /// when absent (the inner node is the terminal).
    pub series: [f64; 3],
    /// The substrate junction's diode card, already at the temperature (its `TNOM` is the
    /// temperature), anode at the substrate for an NPN of vertical or a PNP of lateral
    /// geometry (ngspice's `type·subs > 0`), at the inner collector or base otherwise: `GMIN`
    /// and the depletion charge `CJS`, no diode current (ngspice-39's `ISS` is 0: the card does
    /// not conduct, [`DiodeParameters::conducts`]; a netlist places GMIN alone, a resistor, when
    /// there is no `CJS`).
    pub substrate: DiodeParameters,
    /// Whether the substrate junction's anode is the substrate node.
    pub substrate_anode: bool,
    /// Adjustments ngspice would warn about (`FC` limited to 0.9999).
    pub warnings: Vec<String>,
}

impl Bjt {
    /// The device of card `p`, instance `inst`, at `celsius` (°C), as `bjttemp.c` computes it.
    ///
    /// # Errors
    /// [`BjtError`] for a parameter outside its domain or a combination that is not modelled
    /// (see the module's documentation).
    pub fn at_temperature(
        p: &BjtParameters,
        inst: &BjtInstance,
        celsius: f64,
    ) -> Result<Self, BjtError> {
        validate(p, inst, celsius)?;
        let mut warnings = Vec::new();
        let mut fc = p.fc;
        if fc > 0.9999 {
            warnings.push(format!("FC = {fc} limited to 0.9999 (as ngspice does)"));
            fc = 0.9999;
        }
        let temp = celsius + ZERO_CELSIUS;
        let tnom = p.tnom + ZERO_CELSIUS;
        let fact1 = tnom / REFTEMP;
        let vt = temp * K_OVER_Q;
        let fact2 = temp / REFTEMP;
        let pbfact_at = |t: f64, fact: f64| {
            let egfet = 1.16 - (7.02e-4 * t * t) / (t + 1108.0);
            let arg = -egfet / (2.0 * BOLTZMANN * t) + 1.115_087_7 / (BOLTZMANN * 2.0 * REFTEMP);
            -2.0 * K_OVER_Q * t * (1.5 * fact.ln() + CHARGE * arg)
        };
        let pbfact = pbfact_at(temp, fact2);
        let pbfact1 = pbfact_at(tnom, fact1);
        let ratlog = (temp / tnom).ln();
        let ratio1 = temp / tnom - 1.0;
        let factlog = ratio1 * p.eg / vt + p.xti * ratlog;
        let bfactor = (ratlog * p.xtb).exp();
        let is = p.is * factlog.exp();
        let ise = p.ise * (factlog / p.ne).exp() / bfactor;
        let isc = p.isc * (factlog / p.nc).exp() / bfactor;
        // Junction potential and zero-bias capacitance at the temperature (`bjttemp.c`).
        let junction = |cj: f64, vj: f64, m: f64| {
            let pbo = (vj - pbfact1) / fact1;
            let gmaold = (vj - pbo) / pbo;
            let pot = fact2 * pbo + pbfact;
            let gmanew = (pot - pbo) / pbo;
            let cap = cj / (1.0 + m * (4e-4 * (tnom - REFTEMP) - gmaold))
                * (1.0 + m * (4e-4 * (temp - REFTEMP) - gmanew));
            (cap, pot)
        };
        // ngspice-39 limits the grading coefficients to 0.999.
        let mut grading = |name: &str, m: f64| {
            if m > GRADING_MAX {
                warnings.push(format!(
                    "{name} = {m} limited to {GRADING_MAX} (as ngspice does)"
                ));
                GRADING_MAX
            } else {
                m
            }
        };
        let (mje, mjc, mjs) = (
            grading("MJE", p.mje),
            grading("MJC", p.mjc),
            grading("MJS", p.mjs),
        );
        let (cje, vje) = junction(p.cje, p.vje, mje);
        let (cjc, vjc) = junction(p.cjc, p.vjc, mjc);
        let (cjs, vjs) = junction(p.cjs, p.vjs, mjs);
        for (parameter, pot) in [("VJE", vje), ("VJC", vjc), ("VJS", vjs)] {
            if pot <= 0.0 {
                return Err(BjtError {
                    parameter,
                    value: pot,
                    reason: "the junction potential is not positive at this temperature",
                });
            }
        }
        let area = inst.area;
        let (base_area, collector_area) = if p.vertical {
            (inst.areab, inst.areac)
        } else {
            (inst.areac, inst.areab)
        };
        let inverse = |x: f64| if x == 0.0 { 0.0 } else { 1.0 / x };
        let core = BjtCore {
            sign: p.polarity.sign(),
            is: is * area,
            is_bc: is * area * base_area,
            vt,
            vtf: p.nf * vt,
            vtr: p.nr * vt,
            ise: ise * area,
            vte: p.ne * vt,
            isc: isc * base_area,
            vtc: p.nc * vt,
            bf: p.bf * bfactor,
            br: p.br * bfactor,
            inv_vaf: inverse(p.vaf),
            inv_var: inverse(p.var),
            inv_ikf: inverse(p.ikf) / area,
            inv_ikr: inverse(p.ikr) / area,
            be: Depletion::new(cje * area, vje, mje, fc),
            bc: Depletion::new(cjc * base_area, vjc, mjc, fc),
            tf: p.tf,
            tr: p.tr,
            vcrit: vt * (vt / (std::f64::consts::SQRT_2 * is * area)).ln(),
            gmin: Diode::GMIN,
            m: inst.m,
        };
        let series = |r: f64| if r == 0.0 { 0.0 } else { r / (area * inst.m) };
        let substrate = DiodeParameters {
            is: 0.0,
            cjo: cjs * collector_area * inst.m,
            vj: vjs,
            m: mjs,
            fc: 0.0,
            reverse: ReverseCurrent::Cubic,
            tnom: celsius,
            conducts: false,
            ..DiodeParameters::default()
        };
        Ok(Self {
            core,
            series: [series(p.rb), series(p.rc), series(p.re)],
            substrate,
            substrate_anode: p.polarity.sign() * if p.vertical { 1.0 } else { -1.0 } > 0.0,
            warnings,
        })
    }
}

fn validate(p: &BjtParameters, inst: &BjtInstance, celsius: f64) -> Result<(), BjtError> {
    let fail = |parameter, value, reason| {
        Err(BjtError {
            parameter,
            value,
            reason,
        })
    };
    let all = [
        ("IS", p.is),
        ("BF", p.bf),
        ("NF", p.nf),
        ("VAF", p.vaf),
        ("IKF", p.ikf),
        ("ISE", p.ise),
        ("NE", p.ne),
        ("BR", p.br),
        ("NR", p.nr),
        ("VAR", p.var),
        ("IKR", p.ikr),
        ("ISC", p.isc),
        ("NC", p.nc),
        ("RB", p.rb),
        ("RC", p.rc),
        ("RE", p.re),
        ("CJE", p.cje),
        ("VJE", p.vje),
        ("MJE", p.mje),
        ("CJC", p.cjc),
        ("VJC", p.vjc),
        ("MJC", p.mjc),
        ("XCJC", p.xcjc),
        ("CJS", p.cjs),
        ("VJS", p.vjs),
        ("MJS", p.mjs),
        ("TF", p.tf),
        ("TR", p.tr),
        ("FC", p.fc),
        ("EG", p.eg),
        ("XTI", p.xti),
        ("XTB", p.xtb),
        ("TNOM", p.tnom),
        ("AREA", inst.area),
        ("AREAB", inst.areab),
        ("AREAC", inst.areac),
        ("M", inst.m),
        ("TEMP", celsius),
    ];
    if let Some((parameter, value)) = all.into_iter().find(|(_, v)| !v.is_finite()) {
        return fail(parameter, value, "must be finite");
    }
    for (parameter, value) in [
        ("IS", p.is),
        ("BF", p.bf),
        ("NF", p.nf),
        ("NE", p.ne),
        ("BR", p.br),
        ("NR", p.nr),
        ("NC", p.nc),
        ("VJE", p.vje),
        ("VJC", p.vjc),
        ("VJS", p.vjs),
        ("AREA", inst.area),
        ("AREAB", inst.areab),
        ("AREAC", inst.areac),
        ("M", inst.m),
    ] {
        if value <= 0.0 {
            return fail(parameter, value, "must be positive");
        }
    }
    for (parameter, value) in [
        ("VAF", p.vaf),
        ("IKF", p.ikf),
        ("ISE", p.ise),
        ("VAR", p.var),
        ("IKR", p.ikr),
        ("ISC", p.isc),
        ("RB", p.rb),
        ("RC", p.rc),
        ("RE", p.re),
        ("CJE", p.cje),
        ("CJC", p.cjc),
        ("CJS", p.cjs),
        ("TF", p.tf),
        ("TR", p.tr),
        ("FC", p.fc),
    ] {
        if value < 0.0 {
            return fail(parameter, value, "must not be negative");
        }
    }
    for (parameter, value) in [("MJE", p.mje), ("MJC", p.mjc), ("MJS", p.mjs)] {
        if value < 0.0 {
            return fail(parameter, value, "must not be negative");
        }
    }
    if !(0.0..=1.0).contains(&p.xcjc) {
        return fail("XCJC", p.xcjc, "must lie in [0, 1]");
    }
    if p.xcjc < 1.0 && p.rb > 0.0 && p.cjc > 0.0 {
        return fail(
            "XCJC",
            p.xcjc,
            "a base–collector capacitance split across RB (XCJC < 1) is not modelled; give \
             XCJC = 1 (all of CJC at the inner base)",
        );
    }
    if p.tf > 0.0 && (p.vaf > 0.0 || p.ikr > 0.0) {
        return fail(
            "TF",
            p.tf,
            "with VAF or IKR the forward diffusion charge TF·I_BE/q_b depends on the \
             base–collector voltage while the base–collector charge does not depend on the \
             base–emitter voltage: no function of the junction voltages has these charges as its \
             gradient, so they are not modelled; drop TF, or VAF and IKR",
        );
    }
    if p.tf > 0.0 && (p.var > 0.0 || p.ikf > 0.0) {
        return fail(
            "TF",
            p.tf,
            "the forward diffusion charge TF·I_BE/q_b with VAR or IKF (a function of V_BE whose \
             co-energy has no closed form) is not modelled; drop TF, or VAR and IKF",
        );
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

/// A junction's ideal current `I_S(e^{v/V_tn} − 1)` (the cubic approach to `−I_S` below
/// `−3V_tn`, `bjtload.c`) and its derivative.
fn junction(v: f64, is: f64, vtn: f64) -> (f64, f64) {
    if v >= -3.0 * vtn {
        let x = v / vtn;
        (is * x.exp_m1(), is * x.exp() / vtn)
    } else {
        let a = 3.0 * vtn / (v * std::f64::consts::E);
        let a3 = a * a * a;
        (-is * (1.0 + a3), is * 3.0 * a3 / v)
    }
}

/// `∫₀^v` of [`junction`], in closed form.
fn junction_integral(v: f64, is: f64, vtn: f64) -> f64 {
    let forward = |v: f64| is * vtn * exp_m1_minus_x(v / vtn);
    let v3 = -3.0 * vtn;
    if v >= v3 {
        return forward(v);
    }
    let c = 3.0 * vtn / std::f64::consts::E;
    forward(v3) - is * (v - v3) + 0.5 * is * c * c * c * (1.0 / (v * v) - 1.0 / (v3 * v3))
}

/// The Gummel–Poon currents and junction charges between the inner collector `C'`, base `B'`
/// and emitter `E'` (`bjtload.c`).
///
/// With the voltages multiplied by the polarity's sign `σ`, `I_BE = I_S(e^{V_BE/(N_F V_t)} − 1)`
/// and `I_BC = I_S'(e^{V_BC/(N_R V_t)} − 1)` (each with its cubic reverse branch; `I_S` and
/// `I_S'` scaled by the areas as [`BjtInstance`] says),
///
/// ```text
/// q_1 = 1/(1 − V_BC/VAF − V_BE/VAR),   q_2 = I_BE/IKF + I_BC/IKR,
/// q_b = q_1(1 + √(1 + 4q_2))/2          (q_b = q_1 without IKF and IKR)
/// I_C = (I_BE − I_BC)/q_b − I_BC/BR − I_LC
/// I_B = I_BE/BF + I_LE + I_BC/BR + I_LC
/// I_LE = ISE(e^{V_BE/(N_E V_t)} − 1) + GMIN·V_BE/M,   I_LC = ISC(…V_BC/(N_C V_t)…) + GMIN·V_BC/M
/// ```
///
/// the terminal currents are `σ·M·I_C` into the collector and `σ·M·I_B` into the base (`GMIN`
/// once per card, as ngspice-39 adds it). The
/// junction charges are `Q_BE = Q_dep(V_BE; CJE, VJE, MJE, FC) + TF·I_BE` and `Q_BC =
/// Q_dep(V_BC; CJC, VJC, MJC, FC) + TR·I_BC` (without `GMIN`), times `M`.
///
/// **Formulation**: two branch charges from the inner emitter, `q_c` to the collector (port
/// `i`) and `q_b` to the base (port `ib`), and one flux per junction, `φ̇_be = V_BE`,
/// `φ̇_bc = V_BC`. The Lagrangian is the co-energy `L = M(W_BE(σφ̇_be) + W_BC(σφ̇_bc))`,
/// `W' = Q`, so each junction's charge is the momentum of its own flux (a junction without
/// charge leaves its flux degenerate). The forces
///
/// ```text
/// f_{q_c} = −(φ̇_be − φ̇_bc),   f_{q_b} = −φ̇_be,
/// f_{φ_bc} = σM·I_C − q̇_c,     f_{φ_be} = q̇_c + q̇_b − σM(I_B + I_C)
/// ```
///
/// (the port voltages `V_CE` and `V_BE`, and the charge balances of the two junctions through a
/// skew-symmetric interconnection) give `q̇_c = σM·I_C − dQ_BC/dt` and `q̇_b = σM·I_B +
/// d(Q_BE + Q_BC)/dt`: the terminal currents with the junctions' charging. The Jacobian is the
/// exact derivative.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct BjtCore {
    sign: f64,
    /// `IS·AREA` at the temperature (A): the base–emitter diode's saturation current.
    is: f64,
    /// The base–collector diode's: `IS·AREA·AREA_B` (`AREAC` for a lateral device).
    is_bc: f64,
    vt: f64,
    /// `N_F·V_t`, `N_R·V_t`.
    vtf: f64,
    vtr: f64,
    /// `ISE·AREA` and `N_E·V_t`.
    ise: f64,
    vte: f64,
    /// `ISC·AREA_B` (`AREAC` for a lateral device) and `N_C·V_t`.
    isc: f64,
    vtc: f64,
    bf: f64,
    br: f64,
    inv_vaf: f64,
    inv_var: f64,
    /// `1/(IKF·AREA)`, `1/(IKR·AREA)`.
    inv_ikf: f64,
    inv_ikr: f64,
    be: Depletion,
    bc: Depletion,
    tf: f64,
    tr: f64,
    /// ngspice's `V_crit = V_t ln(V_t/(√2 I_S))` for the junction limiting.
    vcrit: f64,
    gmin: f64,
    m: f64,
}

/// The core's DC currents (polarity applied to the voltages, not to the currents) and their
/// partial derivatives.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct BjtCurrents {
    /// The collector current `I_C` (A), per device (without `M`).
    pub ic: f64,
    /// The base current `I_B` (A), per device.
    pub ib: f64,
    /// `∂I_C/∂V_BE`, `∂I_C/∂V_BC`.
    pub dic: [f64; 2],
    /// `∂I_B/∂V_BE`, `∂I_B/∂V_BC`.
    pub dib: [f64; 2],
}

impl BjtCore {
    /// The port of the base branch (inner base to inner emitter); the collector branch is `i`.
    pub const BASE_PORT: &'static str = "ib";

    /// The same core with conductance `gmin` (S, ≥ 0) across each junction instead of
    /// [`Diode::GMIN`] (ngspice's `.options gmin`).
    #[must_use]
    pub fn with_gmin(mut self, gmin: f64) -> Self {
        self.gmin = gmin.max(0.0);
        self
    }

    /// The currents at junction voltages `vbe`, `vbc` (polarity applied: an NPN's voltages, a
    /// PNP's negated).
    #[must_use]
    pub fn currents(&self, vbe: f64, vbc: f64) -> BjtCurrents {
        let (cbe, gbe) = junction(vbe, self.is, self.vtf);
        let (cbc, gbc) = junction(vbc, self.is_bc, self.vtr);
        // GMIN once per card, not per parallel device (ngspice-39 scales the saturation
        // currents by `M`, not GMIN).
        let gmin = self.gmin / self.m;
        let leak = |v: f64, is: f64, vtn: f64| {
            let (i, g) = if is == 0.0 {
                (0.0, 0.0)
            } else {
                junction(v, is, vtn)
            };
            (i + gmin * v, g + gmin)
        };
        let (cben, gben) = leak(vbe, self.ise, self.vte);
        let (cbcn, gbcn) = leak(vbc, self.isc, self.vtc);
        let q1 = 1.0 / (1.0 - self.inv_vaf * vbc - self.inv_var * vbe);
        let (qb, dqbdve, dqbdvc) = if self.inv_ikf == 0.0 && self.inv_ikr == 0.0 {
            (q1, q1 * q1 * self.inv_var, q1 * q1 * self.inv_vaf)
        } else {
            let q2 = self.inv_ikf * cbe + self.inv_ikr * cbc;
            let arg = (1.0 + 4.0 * q2).max(0.0);
            let sqarg = if arg == 0.0 { 1.0 } else { arg.sqrt() };
            let qb = q1 * (1.0 + sqarg) / 2.0;
            if arg == 0.0 {
                (qb, q1 * qb * self.inv_var, q1 * qb * self.inv_vaf)
            } else {
                (
                    qb,
                    q1 * (qb * self.inv_var + self.inv_ikf * gbe / sqarg),
                    q1 * (qb * self.inv_vaf + self.inv_ikr * gbc / sqarg),
                )
            }
        };
        let transport = (cbe - cbc) / qb;
        BjtCurrents {
            ic: transport - cbc / self.br - cbcn,
            ib: cbe / self.bf + cben + cbc / self.br + cbcn,
            dic: [
                gbe / qb - transport / qb * dqbdve,
                -gbc / qb - transport / qb * dqbdvc - gbc / self.br - gbcn,
            ],
            dib: [gbe / self.bf + gben, gbc / self.br + gbcn],
        }
    }

    /// Whether the junctions store charge (a capacitance or a transit time).
    #[must_use]
    pub fn has_charge(&self) -> bool {
        self.has_be_charge() || self.has_bc_charge()
    }

    /// Whether the base–emitter junction stores charge (`CJE` or `TF`).
    fn has_be_charge(&self) -> bool {
        self.be.charge(0.0).1 > 0.0 || self.tf > 0.0
    }

    /// Whether the base–collector junction stores charge (`CJC` or `TR`).
    fn has_bc_charge(&self) -> bool {
        self.bc.charge(0.0).1 > 0.0 || self.tr > 0.0
    }

    /// The base–emitter charge `Q_BE(v)` and capacitance (polarity applied, per device).
    #[must_use]
    pub fn charge_be(&self, v: f64) -> (f64, f64) {
        let (q, c) = self.be.charge(v);
        let (i, g) = junction(v, self.is, self.vtf);
        (q + self.tf * i, c + self.tf * g)
    }

    /// The base–collector charge `Q_BC(v)` and capacitance (polarity applied, per device).
    #[must_use]
    pub fn charge_bc(&self, v: f64) -> (f64, f64) {
        let (q, c) = self.bc.charge(v);
        let (i, g) = junction(v, self.is_bc, self.vtr);
        (q + self.tr * i, c + self.tr * g)
    }

    /// The co-energy `W_BE(v) + W_BC(w)` (per device, polarity applied).
    fn co_energy(&self, vbe: f64, vbc: f64) -> f64 {
        self.be.integral(vbe)
            + self.tf * junction_integral(vbe, self.is, self.vtf)
            + self.bc.integral(vbc)
            + self.tr * junction_integral(vbc, self.is_bc, self.vtr)
    }

    /// This part as a subsystem named `name`: port `i` (inner collector to inner emitter) and
    /// `ib` (inner base to inner emitter).
    pub fn subsystem(self, name: impl Into<String>) -> Subsystem {
        Subsystem::new(name, self)
            .with_port("i", 0)
            .with_port(Self::BASE_PORT, 2)
    }

    /// `(V_BE, V_BC)` with the polarity applied, from the flux rates.
    fn voltages(&self, v: &[f64]) -> (f64, f64) {
        (self.sign * v[3], self.sign * v[1])
    }
}

impl Model for BjtCore {
    fn dim(&self) -> usize {
        4
    }
    fn lagrangian(&self, _q: &[f64], v: &[f64]) -> f64 {
        if !self.has_charge() {
            return 0.0;
        }
        let (vbe, vbc) = self.voltages(v);
        self.m * self.co_energy(vbe, vbc)
    }
    fn lagrangian_gradient(&self, _q: &[f64], v: &[f64], lq: &mut [f64], lv: &mut [f64]) {
        lq.fill(0.0);
        lv.fill(0.0);
        let (vbe, vbc) = self.voltages(v);
        let s = self.sign * self.m;
        if self.has_bc_charge() {
            lv[1] = s * self.charge_bc(vbc).0;
        }
        if self.has_be_charge() {
            lv[3] = s * self.charge_be(vbe).0;
        }
    }
    fn lagrangian_hessian(&self, _q: &[f64], v: &[f64], h: &mut LagrangianHessian) {
        // Each junction's charge is a function of its own flux rate: a diagonal entry for each
        // junction that stores charge, none for one that does not (its flux is then degenerate).
        let (vbe, vbc) = self.voltages(v);
        if self.has_bc_charge() {
            h.vv.add(1, 1, self.m * self.charge_bc(vbc).1);
        }
        if self.has_be_charge() {
            h.vv.add(3, 3, self.m * self.charge_be(vbe).1);
        }
    }
    fn has_force(&self) -> bool {
        true
    }
    fn force(&self, _q: &[f64], v: &[f64], _t: f64, f: &mut [f64]) {
        let (vbe, vbc) = self.voltages(v);
        let c = self.currents(vbe, vbc);
        let s = self.sign * self.m;
        f[0] = v[1] - v[3];
        f[1] = s * c.ic - v[0];
        f[2] = -v[3];
        f[3] = v[0] + v[2] - s * (c.ib + c.ic);
    }
    fn force_jacobian(&self, _q: &[f64], v: &[f64], _t: f64, j: &mut ForceJacobian) {
        let (vbe, vbc) = self.voltages(v);
        let c = self.currents(vbe, vbc);
        // d(σ·I(σφ̇_be, σφ̇_bc)) = ∂_be I dφ̇_be + ∂_bc I dφ̇_bc (σ² = 1).
        let m = self.m;
        j.v.add(0, 1, 1.0);
        j.v.add(0, 3, -1.0);
        j.v.add(1, 0, -1.0);
        j.v.add(1, 1, m * c.dic[1]);
        j.v.add(1, 3, m * c.dic[0]);
        j.v.add(2, 3, -1.0);
        j.v.add(3, 0, 1.0);
        j.v.add(3, 2, 1.0);
        j.v.add(3, 1, -m * (c.dib[1] + c.dic[1]));
        j.v.add(3, 3, -m * (c.dib[0] + c.dic[0]));
    }
    fn is_autonomous(&self) -> bool {
        true
    }
    fn has_update_limit(&self) -> bool {
        true
    }
    /// ngspice's `DEVpnjlim` on `V_BE` and `V_BC` (with `V_t` and `V_crit` of `IS`, as
    /// `bjtload.c` calls it; the forward step made monotone as in
    /// [`Diode::limit_junction_voltage`]), as the fraction of the update that keeps both within
    /// their limits.
    fn update_fraction(&self, _q: &[f64], v: &[f64], _dq: &[f64], dv: &[f64]) -> f64 {
        let (vbe, vbc) = self.voltages(v);
        let (dbe, dbc) = self.voltages(dv);
        let mut alpha = 1.0_f64;
        for (old, step) in [(vbe, dbe), (vbc, dbc)] {
            if step == 0.0 {
                continue;
            }
            let new = old + step;
            let limited = pnjlim(new, old, self.vt, self.vcrit);
            if limited != new {
                let a = (limited - old) / step;
                if a > 0.0 && a <= 1.0 {
                    alpha = alpha.min(a);
                }
            }
        }
        alpha
    }
    fn coordinate_name(&self, i: usize) -> String {
        ["q_c", "phi_bc", "q_b", "phi_be"]
            .get(i)
            .map_or_else(|| format!("q{i}"), |s| (*s).to_owned())
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::testing::check_model;

    fn card() -> BjtParameters {
        BjtParameters {
            is: 1e-15,
            bf: 120.0,
            br: 2.0,
            nf: 1.02,
            nr: 1.05,
            vaf: 60.0,
            var: 20.0,
            ikf: 0.05,
            ikr: 0.01,
            ise: 2e-14,
            ne: 1.6,
            isc: 1e-14,
            nc: 1.8,
            cje: 5e-12,
            cjc: 3e-12,
            tr: 40e-9,
            ..BjtParameters::new(BjtPolarity::Npn)
        }
    }

    fn core(p: &BjtParameters) -> BjtCore {
        Bjt::at_temperature(p, &BjtInstance::default(), 27.0)
            .unwrap()
            .core
    }

    /// Forward active, by hand: without Early voltages and knee currents
    /// `I_C = I_S e^{V_BE/V_t}(1 − …)`, `I_B = I_C/BF`; the Early effect raises `I_C` by `q_1`.
    #[test]
    fn currents_by_hand() {
        let plain = core(&BjtParameters {
            is: 1e-15,
            bf: 100.0,
            ..BjtParameters::new(BjtPolarity::Npn)
        });
        let vt = Diode::thermal_voltage_at(27.0);
        let (vbe, vbc) = (0.65, -2.0);
        let ibe = 1e-15 * (vbe / vt).exp_m1();
        let ibc = 1e-15 * (vbc / vt).exp_m1();
        let c = plain.currents(vbe, vbc);
        let gmin = Diode::GMIN;
        let close = |a: f64, b: f64| (a - b).abs() <= 1e-13 * b.abs();
        assert!(close(c.ic, ibe - ibc - ibc - gmin * vbc));
        assert!(close(c.ib, ibe / 100.0 + gmin * vbe + ibc + gmin * vbc));
        let early = core(&BjtParameters {
            vaf: 50.0,
            ..BjtParameters::new(BjtPolarity::Npn)
        });
        let q1 = 1.0 / (1.0 + 2.0 / 50.0);
        let e = early.currents(vbe, vbc);
        let is16 = |v: f64| 1e-16 * (v / vt).exp_m1();
        assert!(close(
            e.ic,
            (is16(vbe) - is16(vbc)) / q1 - is16(vbc) - gmin * vbc
        ));
    }

    /// The Jacobian and the Lagrangian's derivatives against central differences, in every
    /// region (forward, saturated, reverse, cut off, below −3·N·V_t), both polarities.
    #[test]
    fn jacobians_match_differences() {
        let with_tf = BjtParameters {
            vaf: 0.0,
            var: 0.0,
            ikf: 0.0,
            ikr: 0.0,
            tf: 0.4e-9,
            ..card()
        };
        for p in [
            card(),
            with_tf,
            BjtParameters {
                polarity: BjtPolarity::Pnp,
                ..card()
            },
        ] {
            let part = core(&p);
            let s = p.polarity.sign();
            for (vbe, vce) in [
                (0.7, 3.0),
                (0.75, 0.1),
                (-0.2, -3.0),
                (-1.0, 2.0),
                (0.3, -0.4),
                (0.68, 0.68),
            ] {
                let v = [1e-3, s * (vbe - vce), 2e-4, s * vbe];
                check_model(&part, &[0.0; 4], &v, 0.0);
            }
        }
    }

    /// The charges: `Q_BE` is the depletion charge plus `TF·I_BE`, its derivative the
    /// capacitance; the co-energy's gradient is the charge (checked by [`check_model`]), and at
    /// zero bias the capacitance is `CJE + TF·I_S/(N_F V_t)`.
    #[test]
    fn zero_bias_capacitance() {
        let p = BjtParameters {
            cje: 2e-12,
            tf: 1e-9,
            ..BjtParameters::new(BjtPolarity::Npn)
        };
        let c = core(&p);
        let vt = Diode::thermal_voltage_at(27.0);
        let (q, cap) = c.charge_be(0.0);
        assert_eq!(q, 0.0);
        assert!((cap - (2e-12 + 1e-9 * 1e-16 / vt)).abs() < 1e-26);
        assert!(!core(&BjtParameters::new(BjtPolarity::Npn)).has_charge());
    }

    /// Temperature (`bjttemp.c`): at TNOM nothing changes; at 127 °C `IS` grows by
    /// `(T/T_nom)^XTI·e^{(T/T_nom − 1)EG/V_t}` and `BF` by `(T/T_nom)^XTB`, and the junction
    /// capacitances are ngspice-39's.
    #[test]
    fn temperature() {
        let p = BjtParameters { xtb: 1.5, ..card() };
        let inst = BjtInstance::default();
        let nominal = Bjt::at_temperature(&p, &inst, 27.0).unwrap().core;
        assert_eq!(nominal.is, 1e-15);
        assert_eq!(nominal.bf, 120.0);
        let hot = Bjt::at_temperature(&p, &inst, 127.0).unwrap().core;
        let ratio: f64 = 400.15 / 300.15;
        let vt = Diode::thermal_voltage_at(127.0);
        let factor = ((ratio - 1.0) * 1.11 / vt + 3.0 * ratio.ln()).exp();
        assert!((hot.is / 1e-15 - factor).abs() < 1e-12 * factor);
        assert!((hot.bf / 120.0 - ratio.powf(1.5)).abs() < 1e-12);
        // The depletion capacitances at 127 °C against TNOM = 27 °C, as ngspice-39 prints them
        // (`@q1[cpi]`, `@q1[cmu]` of a card with CJE = 10p, VJE = 0.8, MJE = 0.4, CJC = 5p,
        // VJC = 0.6, MJC = 0.3 at V_BE = −1, V_BC = −6).
        let caps = Bjt::at_temperature(
            &BjtParameters {
                is: 1e-15,
                cje: 10e-12,
                vje: 0.8,
                mje: 0.4,
                cjc: 5e-12,
                vjc: 0.6,
                mjc: 0.3,
                ..BjtParameters::new(BjtPolarity::Npn)
            },
            &inst,
            127.0,
        )
        .unwrap()
        .core;
        assert!((caps.charge_be(-1.0).1 - 7.524582302363e-12).abs() < 1e-23);
        assert!((caps.charge_bc(-6.0).1 - 2.398702934666e-12).abs() < 1e-23);
    }

    /// Cards that are refused: TF with VAF (not integrable), TF with IKF (not modelled), a
    /// negative capacitance, XCJC < 1 across RB.
    #[test]
    fn refused_cards() {
        let inst = BjtInstance::default();
        let refused = |p: BjtParameters, name: &str| {
            let e = Bjt::at_temperature(&p, &inst, 27.0).unwrap_err();
            assert_eq!(e.parameter, name, "{e}");
        };
        let plain = BjtParameters::new(BjtPolarity::Npn);
        refused(
            BjtParameters {
                tf: 1e-9,
                vaf: 50.0,
                ..plain
            },
            "TF",
        );
        refused(
            BjtParameters {
                tf: 1e-9,
                ikf: 0.1,
                ..plain
            },
            "TF",
        );
        refused(
            BjtParameters {
                cje: -1e-12,
                ..plain
            },
            "CJE",
        );
        refused(
            BjtParameters {
                xcjc: 0.5,
                rb: 10.0,
                cjc: 1e-12,
                ..plain
            },
            "XCJC",
        );
        assert!(Bjt::at_temperature(&BjtParameters { tf: 1e-9, ..plain }, &inst, 27.0).is_ok());
    }

    /// The limiting follows `DEVpnjlim`: a jump of the base–emitter voltage from 0 to 5 V is cut
    /// to `V_t ln(5/V_t)` (the old voltage is not positive).
    #[test]
    fn junction_limiting() {
        let c = core(&card());
        let v = [0.0; 4];
        let dv = [0.0, 0.0, 0.0, 5.0];
        let a = c.update_fraction(&[0.0; 4], &v, &[0.0; 4], &dv);
        let vt = Diode::thermal_voltage_at(27.0);
        assert!((a * 5.0 - vt * (5.0 / vt).ln()).abs() < 1e-12);
        assert_eq!(
            c.update_fraction(&[0.0; 4], &v, &[0.0; 4], &[0.0, 0.0, 0.0, 1e-3]),
            1.0
        );
    }
}
