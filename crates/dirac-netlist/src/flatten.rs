//! Subcircuit expansion and parameter evaluation: syntax tree to a flat [`Netlist`].
//!
//! Parameters are evaluated lazily, so a `.param` may refer to one defined later in the same
//! scope; a cycle is an error. Each `X` instance opens a scope holding its parameters (the
//! subcircuit's defaults, overridden by the instance's `name=value`s, evaluated in the caller's
//! scope) and the `.param`s of the body; names not found there are looked up in the enclosing
//! instance's scope and so on up to the top level. Subcircuit and model definitions are looked up
//! the same way, innermost first.

use std::cell::{Cell, RefCell};
use std::collections::{HashMap, HashSet};
use std::rc::Rc;

use super::error::{ErrorKind, NetlistError, Pos, Warning};
use super::expr::{self, Env, ExprTok, FuncDef};
use super::parser::PolyControls;
use super::parser::{Block, ElemKind, ModelDef, Name, Parsed, SourceFn, SubcktDef, TranCard};
use super::source::SourceSpec;
use super::{ControlledSource, DiodeModel, Element, Netlist, Origin, Sensing, Tran};
use dirac_components::{
    Bjt, BjtInstance, BjtParameters, BjtPolarity, Diode, DiodeParameters, Expression, Mosfet,
    MosfetGeometry, MosfetParameters, Operator, Polarity, Waveform,
};

enum Slot {
    Value(f64),
    Pending(ExprTok),
    Evaluating,
}

/// One level of parameter scope.
struct Scope<'p> {
    parent: Option<&'p Scope<'p>>,
    slots: RefCell<HashMap<String, Slot>>,
    /// The `.func`s defined at this level.
    funcs: RefCell<HashMap<String, Rc<FuncDef>>>,
    /// The circuit's temperature in °C (set on the top-level scope, read through the parents).
    temperature: Cell<f64>,
    /// How many parameter evaluations are in progress, shared by all scopes.
    depth: Rc<Cell<usize>>,
}

/// Bound on the nesting of parameters defined through each other: the sum of the expression
/// depths along the chain being evaluated (keeps evaluation far from a stack overflow).
const MAX_PARAM_DEPTH: usize = 400;

/// Deepest subcircuit nesting.
const MAX_SUBCKT_DEPTH: usize = 50;

/// Most elements and instances subcircuit expansion may create (cards written at the top level
/// are not counted: their cost is that of reading them). Nested instances multiply: ten levels of
/// ten instances are 10¹⁰ elements, which would exhaust memory instead of failing (found by
/// fuzzing, `fuzz/regressions/netlist/exponential_subckt.cir`). 10⁵ is the size of the largest
/// benchmark ladder; expanding that many takes well under a second and about 50 MB (a flat
/// netlist of any size is read as written).
const MAX_EXPANDED: usize = 100_000;

impl<'p> Scope<'p> {
    fn new(parent: Option<&'p Scope<'p>>) -> Self {
        Self {
            parent,
            slots: RefCell::new(HashMap::new()),
            funcs: RefCell::new(HashMap::new()),
            temperature: Cell::new(parent.map_or(27.0, |p| p.temperature.get())),
            depth: parent.map_or_else(|| Rc::new(Cell::new(0)), |p| Rc::clone(&p.depth)),
        }
    }

    fn define(&self, name: &str, slot: Slot) {
        self.slots.borrow_mut().insert(name.to_owned(), slot);
    }

    fn lookup(&self, name: &str, pos: Pos) -> Result<f64, NetlistError> {
        let pending = {
            let mut slots = self.slots.borrow_mut();
            match slots.get_mut(name) {
                None => None,
                Some(Slot::Value(v)) => return Ok(*v),
                Some(Slot::Evaluating) => {
                    return Err(NetlistError::new(
                        ErrorKind::RecursiveParam,
                        pos,
                        name,
                        format!("parameter `{name}` depends on itself"),
                    ));
                }
                Some(slot @ Slot::Pending(_)) => match std::mem::replace(slot, Slot::Evaluating) {
                    Slot::Pending(e) => Some(e),
                    _ => None,
                },
            }
        };
        match pending {
            Some(e) => {
                let depth = self.depth.get() + e.depth;
                if depth > MAX_PARAM_DEPTH {
                    return Err(NetlistError::new(
                        ErrorKind::Unsupported,
                        pos,
                        name,
                        format!("parameter `{name}`: definitions nested this deep not supported"),
                    ));
                }
                self.depth.set(depth);
                let v = self.eval(&e);
                self.depth.set(depth - e.depth);
                let v = v?;
                self.define(name, Slot::Value(v));
                Ok(v)
            }
            None => match self.parent {
                Some(parent) => parent.lookup(name, pos),
                None => Err(NetlistError::new(
                    ErrorKind::UnknownParam,
                    pos,
                    name,
                    format!("unknown parameter `{name}`"),
                )),
            },
        }
    }

    /// Evaluates an expression in this scope; the result must be finite.
    fn eval(&self, e: &ExprTok) -> Result<f64, NetlistError> {
        let v = expr::eval(&e.expr, self)?;
        if v.is_finite() {
            Ok(v)
        } else {
            Err(NetlistError::bad_value(
                e.pos,
                e.text.clone(),
                format!("`{}` evaluates to {v}", e.text),
            ))
        }
    }
}

impl Env for Scope<'_> {
    fn param(&self, name: &str, pos: Pos) -> Result<f64, NetlistError> {
        self.lookup(name, pos)
    }
    fn temperature(&self) -> f64 {
        self.temperature.get()
    }
    fn function(&self, name: &str) -> Option<Rc<FuncDef>> {
        match self.funcs.borrow().get(name) {
            Some(def) => Some(Rc::clone(def)),
            None => self.parent.and_then(|p| p.function(name)),
        }
    }
}

impl Scope<'_> {
    /// Defines the `.func`s of a block at this level.
    fn define_functions(&self, funcs: &[(Name, FuncDef)]) {
        let mut table = self.funcs.borrow_mut();
        for (name, def) in funcs {
            table.insert(name.norm.clone(), Rc::new(def.clone()));
        }
    }
}

/// One level of instance expansion.
struct Ctx<'a, 'p> {
    block: &'a Block,
    scope: &'p Scope<'p>,
    parent: Option<&'p Ctx<'a, 'p>>,
    /// Hierarchical instance name (`x1.x2`), empty at the top level.
    prefix: String,
    /// The same as written.
    orig_prefix: String,
    /// Port name → caller's node.
    ports: HashMap<String, String>,
    def: Option<&'a SubcktDef>,
    /// Nodes named on `.global` cards: the same node inside every subcircuit.
    globals: &'a HashSet<String>,
}

impl<'a, 'p> Ctx<'a, 'p> {
    /// The `.model` named `model` that `device` `element` uses, and the scope it is evaluated
    /// in, innermost first; an error at the model's name when there is none.
    fn model(
        &self,
        model: &Name,
        device: &str,
        element: &Name,
    ) -> Result<(&'a ModelDef, &'p Scope<'p>), NetlistError> {
        let mut c = Some(self);
        while let Some(cx) = c {
            if let Some(def) = cx.block.models.iter().find(|d| d.name.norm == model.norm) {
                return Ok((def, cx.scope));
            }
            c = cx.parent;
        }
        Err(NetlistError::new(
            ErrorKind::MissingModel,
            model.pos,
            model.orig.clone(),
            format!(
                "{device} `{}` uses undefined model `{}`",
                element.orig, model.orig
            ),
        ))
    }

    fn join(prefix: &str, name: &str) -> String {
        if prefix.is_empty() {
            name.to_owned()
        } else {
            format!("{prefix}.{name}")
        }
    }

    fn node(&self, n: &Name) -> String {
        if n.norm == "0" {
            return "0".to_owned();
        }
        match self.ports.get(&n.norm) {
            Some(mapped) => mapped.clone(),
            None if self.globals.contains(&n.norm) => n.norm.clone(),
            None => Self::join(&self.prefix, &n.norm),
        }
    }
}

struct KRef {
    index: usize,
    l1: (String, Name),
    l2: (String, Name),
}

#[derive(Default)]
struct Out {
    elements: Vec<Element>,
    origins: Vec<Origin>,
    /// Hierarchical name → element index (`None` for subcircuit instances).
    names: HashMap<String, Option<usize>>,
    krefs: Vec<KRef>,
    /// The circuit's temperature and `TNOM` in °C.
    temperatures: (f64, f64),
    /// A MOSFET's geometry when its card gives none (`.options defl defw defad defas`).
    mos_defaults: MosfetGeometry,
    /// Inductors written with `m=`, `scale=` or a temperature factor other than 1 (hierarchical
    /// names): a K card may not couple them.
    multiplied_inductors: HashSet<String>,
    /// `F`/`H` sources' controlling voltage sources: (element index, hierarchical name, as written).
    vrefs: Vec<(usize, String, Name)>,
    ics: Vec<(String, f64, Name)>,
    warnings: Vec<Warning>,
    /// Elements and instances created inside subcircuits so far.
    expanded: usize,
    /// MOSFET instance parameters set by name (`"x1.m2.w"`, lowercase), over the card's.
    instance_values: Vec<(String, f64)>,
}

impl Out {
    fn claim(
        &mut self,
        full: &str,
        name: &Name,
        orig: &str,
        index: Option<usize>,
    ) -> Result<(), NetlistError> {
        if self.names.contains_key(full) {
            return Err(NetlistError::new(
                ErrorKind::DuplicateElement,
                name.pos,
                name.orig.clone(),
                format!("element `{orig}` defined twice"),
            ));
        }
        self.names.insert(full.to_owned(), index);
        Ok(())
    }
}

fn source(
    f: &SourceFn,
    scope: &Scope<'_>,
    warnings: &mut Vec<Warning>,
) -> Result<SourceSpec, NetlistError> {
    let eval_all = |args: &[ExprTok]| -> Result<Vec<f64>, NetlistError> {
        args.iter().map(|a| scope.eval(a)).collect()
    };
    let non_negative = |args: &[ExprTok], vals: &[f64], from: usize, what: &[&str]| {
        for (k, name) in what.iter().enumerate() {
            let i = from + k;
            if let (Some(a), Some(&v)) = (args.get(i), vals.get(i))
                && v < 0.0
            {
                return Err(NetlistError::bad_value(
                    a.pos,
                    a.text.clone(),
                    format!("{name} must not be negative, got `{}` = {v}", a.text),
                ));
            }
        }
        Ok(())
    };
    Ok(match f {
        SourceFn::Dc(v) => SourceSpec::Dc(scope.eval(v)?),
        SourceFn::Sin(args) => {
            let v = eval_all(args)?;
            let at = |i: usize| v.get(i).copied().unwrap_or(0.0);
            SourceSpec::Sin {
                vo: at(0),
                va: at(1),
                freq: at(2),
                td: at(3),
                theta: at(4),
                phase: at(5),
            }
        }
        SourceFn::Pulse(args) => {
            let v = eval_all(args)?;
            non_negative(
                args,
                &v,
                3,
                &[
                    "PULSE rise time",
                    "PULSE fall time",
                    "PULSE width",
                    "PULSE period",
                ],
            )?;
            let at = |i: usize| v.get(i).copied().unwrap_or(0.0);
            SourceSpec::Pulse {
                v1: at(0),
                v2: at(1),
                td: at(2),
                tr: at(3),
                tf: at(4),
                pw: at(5),
                per: at(6),
                np: at(7),
            }
        }
        SourceFn::Exp(args) => {
            let v = eval_all(args)?;
            non_negative(args, &v, 3, &["EXP rise time constant"])?;
            non_negative(args, &v, 5, &["EXP fall time constant"])?;
            let at = |i: usize| v.get(i).copied().unwrap_or(0.0);
            SourceSpec::Exp {
                v1: at(0),
                v2: at(1),
                td1: at(2),
                tau1: at(3),
                td2: at(4),
                tau2: at(5),
            }
        }
        SourceFn::Sffm(args) => {
            let v = eval_all(args)?;
            non_negative(args, &v, 2, &["SFFM carrier frequency"])?;
            non_negative(args, &v, 4, &["SFFM signal frequency"])?;
            let at = |i: usize| v.get(i).copied().unwrap_or(0.0);
            SourceSpec::Sffm {
                vo: at(0),
                va: at(1),
                fc: at(2),
                mdi: at(3),
                fs: at(4),
                phasec: at(5),
                phases: at(6),
            }
        }
        SourceFn::Am(args) => {
            let v = eval_all(args)?;
            non_negative(
                args,
                &v,
                2,
                &["AM modulating frequency", "AM carrier frequency"],
            )?;
            let at = |i: usize| v.get(i).copied().unwrap_or(0.0);
            SourceSpec::Am {
                va: at(0),
                vo: at(1),
                mf: at(2),
                fc: at(3),
                td: at(4),
                phasec: at(5),
                phases: at(6),
            }
        }
        SourceFn::Pwl(args, repeat, delay) => {
            let v = eval_all(args)?;
            let points: Vec<(f64, f64)> = v.chunks_exact(2).map(|c| (c[0], c[1])).collect();
            for k in 1..points.len() {
                if points[k].0 == points[k - 1].0 {
                    let a = &args[2 * k];
                    warnings.push(Warning::new(
                        a.pos,
                        a.text.clone(),
                        format!(
                            "PWL time `{}` = {} repeated: the waveform jumps there",
                            a.text, points[k].0
                        ),
                    ));
                }
                if points[k].0 < points[k - 1].0 {
                    let a = &args[2 * k];
                    return Err(NetlistError::bad_value(
                        a.pos,
                        a.text.clone(),
                        format!(
                            "PWL times must not decrease: `{}` = {} after {}",
                            a.text,
                            points[k].0,
                            points[k - 1].0
                        ),
                    ));
                }
            }
            let td = delay
                .as_ref()
                .map(|d| scope.eval(d))
                .transpose()?
                .unwrap_or(0.0);
            let r = match repeat {
                None => None,
                Some(a) => {
                    let r = scope.eval(a)?;
                    if Waveform::pwl_repeat_fault(&points, r).is_some() {
                        let last = points.last().map_or(f64::NAN, |p| p.0);
                        return Err(NetlistError::bad_value(
                            a.pos,
                            a.text.clone(),
                            format!(
                                "PWL repeat time `r={}` = {r} must be one of the time points before \
                                 the last ({last})",
                                a.text
                            ),
                        ));
                    }
                    Some(r)
                }
            };
            SourceSpec::Pwl { points, td, r }
        }
    })
}

fn diode_model(
    model: &ModelDef,
    scope: &Scope<'_>,
    out: &mut Out,
) -> Result<DiodeModel, NetlistError> {
    let mut m = DiodeModel {
        name: model.name.norm.clone(),
        card: DiodeParameters::default(),
        tnom_given: false,
        ignored: Vec::new(),
        temp: None,
    };
    let c = &mut m.card;
    for (name, e) in &model.params {
        let v = scope.eval(e)?;
        let bad = |what: &str| {
            NetlistError::bad_value(
                e.pos,
                e.text.clone(),
                format!(
                    "diode model `{}`: {} must be {what}, got {v}",
                    model.name.orig, name.orig
                ),
            )
        };
        let positive = |v: f64| if v > 0.0 { Ok(v) } else { Err(bad("positive")) };
        let non_negative = |v: f64| {
            if v >= 0.0 {
                Ok(v)
            } else {
                Err(bad("non-negative"))
            }
        };
        match name.norm.as_str() {
            "is" | "js" => c.is = positive(v)?,
            "n" => c.n = positive(v)?,
            "rs" => c.rs = non_negative(v)?,
            "cjo" | "cj0" | "cj" => c.cjo = non_negative(v)?,
            "vj" | "pb" => c.vj = positive(v)?,
            "m" | "mj" => c.m = non_negative(v)?,
            "fc" => c.fc = non_negative(v)?,
            "tt" => c.tt = non_negative(v)?,
            "bv" => c.bv = Some(positive(v)?),
            "ibv" | "ib" => c.ibv = positive(v)?,
            "nbv" => c.nbv = Some(positive(v)?),
            "eg" => c.eg = positive(v)?,
            "xti" => c.xti = v,
            "tnom" | "tref" => {
                c.tnom = v;
                m.tnom_given = true;
            }
            "tcv" => c.tcv = v,
            "trs" | "trs1" => c.trs[0] = v,
            "trs2" => c.trs[1] = v,
            "ttt1" => c.ttt[0] = v,
            "ttt2" => c.ttt[1] = v,
            "tm1" => c.tm[0] = v,
            "tm2" => c.tm[1] = v,
            // ngspice takes a model's AREA as the default of its instances' area.
            "area" => c.area = v,
            "level" if v == 1.0 => {}
            other => {
                out.warnings.push(Warning::new(
                    name.pos,
                    name.orig.clone(),
                    format!(
                        "diode model `{}`: parameter `{}` ignored: {}",
                        model.name.orig,
                        name.orig,
                        unsupported_diode_parameter(other)
                    ),
                ));
                m.ignored.push((other.to_owned(), v));
            }
        }
    }
    // The card's own consistency (FC < 1, ...), checked at its nominal temperature.
    Diode::at_temperature(&m.card, m.card.tnom).map_err(|err| {
        NetlistError::bad_value(
            model.name.pos,
            model.name.orig.clone(),
            format!("diode model `{}`: {err}", model.name.orig),
        )
    })?;
    Ok(m)
}

/// The variant a device's `.model` kind names (`kinds`: lowercase kind and variant), or the
/// error at the name it was used by: `device` `element` uses a model of another kind.
fn model_kind<P: Copy>(
    model: &ModelDef,
    element: &Name,
    used_as: &Name,
    device: &str,
    kinds: &[(&str, P)],
) -> Result<P, NetlistError> {
    kinds
        .iter()
        .find(|(kind, _)| *kind == model.kind.norm)
        .map(|&(_, variant)| variant)
        .ok_or_else(|| {
            NetlistError::new(
                ErrorKind::MissingModel,
                used_as.pos,
                used_as.orig.clone(),
                format!(
                    "{device} `{}` uses model `{}`, which is a `{}` model, not a {device}'s",
                    element.orig, used_as.orig, model.kind.orig
                ),
            )
        })
}

/// A `.model NMOS|PMOS` card as a level-1 MOSFET's parameters (`TNOM` from `.options` unless
/// given). A card of another level is refused at the element using it (a model library may hold
/// BSIM cards for devices a netlist does not use); parameters that only matter with `TOX` or
/// for noise are ignored with a warning.
fn mosfet_model(
    model: &ModelDef,
    scope: &Scope<'_>,
    element: &Name,
    used_as: &Name,
    out: &mut Out,
) -> Result<MosfetParameters, NetlistError> {
    let polarity = model_kind(
        model,
        element,
        used_as,
        "MOSFET",
        &[("nmos", Polarity::N), ("pmos", Polarity::P)],
    )?;
    let mut c = MosfetParameters::new(polarity);
    c.tnom = out.temperatures.1;
    for (name, e) in &model.params {
        let v = scope.eval(e)?;
        match name.norm.as_str() {
            "level" if v == 1.0 => {}
            "level" => {
                return Err(NetlistError::unsupported_in(
                    e.pos,
                    &e.text,
                    &format!(
                        "MOSFET level {v} (model `{}`; only level 1, Shichman–Hodges, is modelled)",
                        model.name.orig
                    ),
                    &format!("level={}", e.text),
                ));
            }
            "vto" | "vt0" => c.vto = v,
            "kp" => c.kp = v,
            "gamma" => c.gamma = v,
            "phi" => c.phi = v,
            "lambda" => c.lambda = v,
            "rd" => c.rd = Some(v),
            "rs" => c.rs = Some(v),
            "rsh" => c.rsh = Some(v),
            "cbd" => c.cbd = Some(v),
            "cbs" => c.cbs = Some(v),
            "is" => c.is = v,
            "js" => c.js = v,
            "pb" => c.pb = v,
            "cj" => c.cj = Some(v),
            "mj" => c.mj = v,
            "cjsw" => c.cjsw = Some(v),
            "mjsw" => c.mjsw = v,
            "fc" => c.fc = v,
            "cgso" => c.cgso = v,
            "cgdo" => c.cgdo = v,
            "cgbo" => c.cgbo = v,
            "ld" => c.ld = v,
            "tox" => c.tox = Some(v),
            "tnom" => c.tnom = v,
            other => {
                let why = match other {
                    "u0" | "uo" | "nsub" | "nss" | "tpg" => {
                        "used only to derive KP, GAMMA, PHI or VTO from TOX, which is not given"
                    }
                    "kf" | "af" => "flicker noise: no effect on a transient or an operating point",
                    _ => "not a level-1 MOSFET parameter; the simulation does not use it",
                };
                out.warnings.push(Warning::new(
                    name.pos,
                    name.orig.clone(),
                    format!(
                        "MOSFET model `{}`: parameter `{}` ignored: {why}",
                        model.name.orig, name.orig
                    ),
                ));
            }
        }
    }
    Ok(c)
}

/// An element's own temperature (°C) from its `temp=` (which wins, as in ngspice) or `dtemp=`
/// (added to the circuit's temperature `circuit`); `None` when neither is given.
fn instance_temperature(
    temp: Option<&ExprTok>,
    dtemp: Option<&ExprTok>,
    scope: &Scope<'_>,
    circuit: f64,
) -> Result<Option<f64>, NetlistError> {
    if let Some(t) = temp {
        return scope.eval(t).map(Some);
    }
    dtemp.map(|d| Ok(circuit + scope.eval(d)?)).transpose()
}

/// The field of a MOSFET's geometry each instance parameter sets, by its name on the card.
type GeometryField = (&'static str, fn(&mut MosfetGeometry) -> &mut f64);

/// The instance parameters of a MOSFET that can be set by name, with the field each sets.
const MOSFET_INSTANCE_FIELDS: [GeometryField; 9] = [
    ("l", |g| &mut g.l),
    ("w", |g| &mut g.w),
    ("ad", |g| &mut g.ad),
    ("as", |g| &mut g.as_),
    ("pd", |g| &mut g.pd),
    ("ps", |g| &mut g.ps),
    ("nrd", |g| &mut g.nrd),
    ("nrs", |g| &mut g.nrs),
    ("m", |g| &mut g.m),
];

/// The instance parameters of a MOSFET that can be set by name, as its card writes them.
pub const MOSFET_INSTANCE_KEYS: [&str; 9] = {
    let mut keys = [""; 9];
    let mut i = 0;
    while i < keys.len() {
        keys[i] = MOSFET_INSTANCE_FIELDS[i].0;
        i += 1;
    }
    keys
};

/// The field of `geometry` an instance parameter `key` (lowercase) sets.
fn geometry_slot<'g>(geometry: &'g mut MosfetGeometry, key: &str) -> Option<&'g mut f64> {
    let (_, field) = MOSFET_INSTANCE_FIELDS.iter().find(|(k, _)| *k == key)?;
    Some(field(geometry))
}

/// An `M` card's instance parameters as a geometry (ngspice's defaults for the rest) and its
/// own temperature, if `temp=` or `dtemp=` gives one.
fn mosfet_geometry(
    params: &[(Name, ExprTok)],
    scope: &Scope<'_>,
    element: &Name,
    out: &mut Out,
) -> Result<(MosfetGeometry, Option<f64>), NetlistError> {
    let mut g = out.mos_defaults;
    let (mut temp, mut dtemp) = (None, None);
    for (name, e) in params {
        if let Some(slot) = geometry_slot(&mut g, &name.norm) {
            *slot = scope.eval(e)?;
            continue;
        }
        match name.norm.as_str() {
            "temp" => temp = Some(e),
            "dtemp" => dtemp = Some(e),
            "icvds" | "icvgs" | "icvbs" | "ic" => {
                out.warnings.push(Warning::new(
                    name.pos,
                    name.orig.clone(),
                    format!(
                        "`{}` of `{}` ignored: initial conditions are set with `.ic` on nodes",
                        name.orig, element.orig
                    ),
                ));
            }
            _ => {
                return Err(NetlistError::new(
                    ErrorKind::Unsupported,
                    name.pos,
                    name.orig.clone(),
                    format!(
                        "MOSFET instance parameter `{}` of `{}` not supported (read: L, W, AD, AS, \
                         PD, PS, NRD, NRS, M, TEMP, DTEMP)",
                        name.orig, element.orig
                    ),
                ));
            }
        }
    }
    Ok((
        g,
        instance_temperature(temp, dtemp, scope, out.temperatures.0)?,
    ))
}

/// An `M` card as the elements it places: the channel (the main element, named `full`) between
/// the inner drain and source, and its series resistances, bulk junctions and overlap
/// capacitances, named `"<card> <what>"`; a junction or capacitance the card's wiring shorts
/// is not placed.
fn mosfet_elements(
    ctx: &Ctx<'_, '_>,
    element: &Name,
    model: &Name,
    params: &[(Name, ExprTok)],
    full: String,
    nodes: &[String],
    out: &mut Out,
) -> Result<(Element, Vec<Element>), NetlistError> {
    let n = |i: usize| nodes.get(i).cloned().unwrap_or_default();
    let mut parts = Vec::new();
    let (def, mscope) = ctx.model(model, "MOSFET", element)?;
    let card = mosfet_model(def, mscope, element, model, out)?;
    let (mut geometry, temp) = mosfet_geometry(params, ctx.scope, element, out)?;
    for (name, value) in &out.instance_values {
        let Some(key) = name
            .strip_prefix(full.as_str())
            .and_then(|rest| rest.strip_prefix('.'))
        else {
            continue;
        };
        if let Some(slot) = geometry_slot(&mut geometry, key) {
            *slot = *value;
        }
    }
    let celsius = temp.unwrap_or(out.temperatures.0);
    let device = Mosfet::at_temperature(&card, &geometry, celsius).map_err(|e| {
        NetlistError::bad_value(
            element.pos,
            element.orig.clone(),
            format!("MOSFET `{}` (model `{}`): {e}", element.orig, model.orig),
        )
    })?;
    let (drain, gate, source, bulk) = (n(0), n(1), n(2), n(3));
    let inner = |node: String, r: f64, which: &str| {
        if r > 0.0 {
            crate::inner_name(&full, which)
        } else {
            node
        }
    };
    let d = inner(drain.clone(), device.series[0], "drain");
    let s = inner(source.clone(), device.series[1], "source");
    for (which, outer, r, inner) in [
        ("rd", &drain, device.series[0], &d),
        ("rs", &source, device.series[1], &s),
    ] {
        if r > 0.0 {
            parts.push(Element::R {
                name: crate::inner_name(&full, which),
                n1: outer.clone(),
                n2: inner.clone(),
                value: r,
            });
        }
    }
    for (which, junction, node) in [
        ("bd", device.drain_junction, &d),
        ("bs", device.source_junction, &s),
    ] {
        // A junction shorted by the card's wiring (source tied to bulk) has no voltage:
        // it is not placed.
        let Some(junction) = junction.filter(|_| *node != bulk) else {
            continue;
        };
        let (anode, cathode) = match card.polarity {
            Polarity::N => (bulk.clone(), node.clone()),
            Polarity::P => (node.clone(), bulk.clone()),
        };
        parts.push(Element::D {
            name: crate::inner_name(&full, which),
            anode,
            cathode,
            model: DiodeModel {
                name: def.name.norm.clone(),
                card: junction,
                tnom_given: true,
                ignored: Vec::new(),
                temp,
            },
        });
    }
    for (which, value, other) in [
        ("cgs", device.overlap[0], &s),
        ("cgd", device.overlap[1], &d),
        ("cgb", device.overlap[2], &bulk),
    ] {
        if value > 0.0 && *other != gate {
            parts.push(Element::C {
                name: crate::inner_name(&full, which),
                n1: gate.clone(),
                n2: other.clone(),
                value,
                ic: None,
            });
        }
    }
    let channel = Element::Controlled {
        name: full,
        n_plus: d,
        n_minus: s.clone(),
        source: ControlledSource::Mosfet {
            gate,
            bulk,
            source: s,
            channel: device.channel,
        },
    };
    Ok((channel, parts))
}

/// A `.model NPN|PNP` card as a Gummel–Poon BJT's parameters (`TNOM` from `.options` unless
/// given). Parameters whose effect is not modelled are refused when they would change the
/// result, ignored with a warning when they would not (noise, safe-operating-area limits).
fn bjt_model(
    model: &ModelDef,
    scope: &Scope<'_>,
    element: &Name,
    used_as: &Name,
    out: &mut Out,
) -> Result<BjtParameters, NetlistError> {
    let polarity = model_kind(
        model,
        element,
        used_as,
        "BJT",
        &[("npn", BjtPolarity::Npn), ("pnp", BjtPolarity::Pnp)],
    )?;
    let mut c = BjtParameters::new(polarity);
    c.tnom = out.temperatures.1;
    let (mut ise, mut c2, mut isc, mut c4) = (None, None, None, None);
    let (mut rbm, mut tf_dependence) = (None, Vec::new());
    for (name, e) in &model.params {
        let v = scope.eval(e)?;
        let refuse = |why: &str| {
            Err(NetlistError::unsupported_in(
                e.pos,
                &e.text,
                &format!(
                    "BJT model `{}` parameter `{}` = {v}: {why}",
                    model.name.orig, name.orig
                ),
                &format!("{}={}", name.orig, e.text),
            ))
        };
        match name.norm.as_str() {
            "level" if v == 1.0 => {}
            "level" => return refuse("only level 1 (Gummel–Poon) is modelled"),
            "is" => c.is = v,
            "bf" => c.bf = v,
            "nf" => c.nf = v,
            "vaf" | "va" => c.vaf = v,
            "ikf" | "ik" => c.ikf = v,
            "ise" => ise = Some(v),
            "c2" => c2 = Some(v),
            "ne" => c.ne = v,
            "br" => c.br = v,
            "nr" => c.nr = v,
            "var" | "vb" => c.var = v,
            "ikr" => c.ikr = v,
            "isc" => isc = Some(v),
            "c4" => c4 = Some(v),
            "nc" => c.nc = v,
            "rb" => c.rb = v,
            "rc" => c.rc = v,
            "re" => c.re = v,
            "cje" => c.cje = v,
            "vje" | "pe" => c.vje = v,
            "mje" | "me" => c.mje = v,
            "cjc" => c.cjc = v,
            "vjc" | "pc" => c.vjc = v,
            "mjc" | "mc" => c.mjc = v,
            "xcjc" => c.xcjc = v,
            "cjs" | "ccs" | "csub" => c.cjs = v,
            "vjs" | "ps" => c.vjs = v,
            "mjs" | "ms" => c.mjs = v,
            "tf" => c.tf = v,
            "tr" => c.tr = v,
            "fc" => c.fc = v,
            "eg" => c.eg = v,
            "xti" => c.xti = v,
            "xtb" => c.xtb = v,
            "tnom" | "tref" => c.tnom = v,
            "subs" if v == 1.0 || v == -1.0 => c.vertical = v == 1.0,
            "subs" => return refuse("SUBS must be 1 (vertical) or -1 (lateral)"),
            "rbm" => rbm = Some(v),
            "nkf" if v == 0.5 => {}
            "nkf" => {
                return refuse(
                    "a high-injection roll-off exponent other than 0.5 is not modelled (ngspice's \
                     derivative for it is not exact either)",
                );
            }
            "xtf" | "ptf" if v != 0.0 => tf_dependence.push((name, e, v)),
            "xtf" | "ptf" => {}
            "irb" if v != 0.0 => {
                return refuse("the current-dependent base resistance (IRB, RBM) is not modelled");
            }
            "iss" if v != 0.0 => {
                return refuse("the substrate junction's diode current (ISS) is not modelled");
            }
            "rco" | "vo" | "gamma" | "qco" | "quasimod" if v != 0.0 => {
                return refuse("quasi-saturation (RCO, VO, GAMMA, QCO) is not modelled");
            }
            "ibe" | "ibc" if v != 0.0 => {
                return refuse(
                    "separate base–emitter and base–collector saturation currents (IBE, IBC) are \
                     not modelled; give IS",
                );
            }
            "tlev" | "tlevc" if v != 0.0 => {
                return refuse("only the default temperature model (TLEV = TLEVC = 0) is modelled");
            }
            "tbf1" | "tbf2" | "tbr1" | "tbr2" | "tikf1" | "tikf2" | "tikr1" | "tikr2" | "tirb1"
            | "tirb2" | "tnc1" | "tnc2" | "tne1" | "tne2" | "tnf1" | "tnf2" | "tnr1" | "tnr2"
            | "trb1" | "trb2" | "trc1" | "trc2" | "tre1" | "tre2" | "trm1" | "trm2" | "tvaf1"
            | "tvaf2" | "tvar1" | "tvar2" | "ctc" | "cte" | "cts" | "tvjc" | "tvje" | "tvjs"
            | "titf1" | "titf2" | "ttf1" | "ttf2" | "ttr1" | "ttr2" | "tmje1" | "tmje2"
            | "tmjc1" | "tmjc2" | "tmjs1" | "tmjs2" | "tns1" | "tns2" | "tis1" | "tis2"
            | "tise1" | "tise2" | "tisc1" | "tisc2"
                if v != 0.0 =>
            {
                return refuse("temperature coefficients beyond XTI, XTB and EG are not modelled");
            }
            other => {
                let why = match other {
                    "kf" | "af" => "flicker noise: no effect on a transient or an operating point",
                    "vbe_max" | "vbc_max" | "vce_max" => {
                        "a safe-operating-area limit: ngspice only warns when it is exceeded"
                    }
                    "vtf" | "itf" => "acts only through XTF, which is zero here",
                    "ns" => "acts only through ISS, which is zero here",
                    "irb" | "iss" | "tlev" | "tlevc" | "xtf" | "ptf" | "rco" | "vo" | "gamma"
                    | "qco" | "quasimod" | "ibe" | "ibc" => "zero: no effect",
                    _ if other.starts_with('t') && v == 0.0 => "zero: no effect",
                    _ => "not a Gummel–Poon parameter; the simulation does not use it",
                };
                out.warnings.push(Warning::new(
                    name.pos,
                    name.orig.clone(),
                    format!(
                        "BJT model `{}`: parameter `{}` ignored: {why}",
                        model.name.orig, name.orig
                    ),
                ));
            }
        }
    }
    if let Some((name, e, v)) = tf_dependence.first()
        && c.tf != 0.0
    {
        return Err(NetlistError::unsupported_in(
            e.pos,
            &e.text,
            &format!(
                "BJT model `{}` parameter `{}` = {v}: the bias dependence of TF (XTF, VTF, ITF) \
                 and excess phase (PTF) are not modelled",
                model.name.orig, name.orig
            ),
            &format!("{}={}", name.orig, e.text),
        ));
    }
    if let Some(r) = rbm
        && r != c.rb
    {
        return Err(NetlistError::unsupported_in(
            model.name.pos,
            &model.name.orig,
            &format!(
                "BJT model `{}`: RBM = {r} differs from RB = {}: the current-dependent base \
                 resistance is not modelled",
                model.name.orig, c.rb
            ),
            &model.name.orig,
        ));
    }
    // `bjttemp.c`: ISE when given, else C2·IS (likewise ISC, C4).
    c.ise = ise.or(c2.map(|k| k * c.is)).unwrap_or(0.0);
    c.isc = isc.or(c4.map(|k| k * c.is)).unwrap_or(0.0);
    Ok(c)
}

/// A `Q` card as the elements it places: the core (the main element, named `full`) between the
/// inner collector, base and emitter, its series resistances and its substrate junction, named
/// `"<card> <what>"`. The words after the three nodes are `[substrate] model [area]`: a first
/// word that names a model is the model (ngspice's rule), else it is the substrate node.
fn bjt_elements(
    ctx: &Ctx<'_, '_>,
    element: &Name,
    words: &[Name],
    params: &[(Name, ExprTok)],
    full: String,
    nodes: &[String],
    out: &mut Out,
) -> Result<(Element, Vec<Element>), NetlistError> {
    let n = |i: usize| nodes.get(i).cloned().unwrap_or_default();
    let (substrate, model, area_word) = match words {
        [first, rest @ ..] if ctx.model(first, "BJT", element).is_ok() => {
            (None, first, rest.first())
        }
        [sub, model, rest @ ..] => (Some(sub), model, rest.first()),
        [only] => (None, only, None),
        [] => {
            return Err(NetlistError::syntax(
                element.pos,
                element.orig.clone(),
                format!("`{}` needs a model name", element.orig),
            ));
        }
    };
    let extra = match words {
        [first, _, extra, ..] if ctx.model(first, "BJT", element).is_ok() => Some(extra),
        _ => None,
    };
    if let Some(extra) = extra {
        return Err(NetlistError::syntax(
            extra.pos,
            extra.orig.clone(),
            format!(
                "`{}` follows the area of `{}`: expected `name=value`",
                extra.orig, element.orig
            ),
        ));
    }
    let (def, mscope) = ctx.model(model, "BJT", element)?;
    let card = bjt_model(def, mscope, element, model, out)?;
    let mut inst = BjtInstance::default();
    let (mut areab, mut areac) = (None, None);
    if let Some(w) = area_word {
        inst.area = match crate::parse_spice_number(&w.orig) {
            Some(a) if a > 0.0 && a.is_finite() => a,
            _ => {
                return Err(NetlistError::bad_value(
                    w.pos,
                    w.orig.clone(),
                    format!(
                        "area of `{}` must be a positive number, got `{}`",
                        element.orig, w.orig
                    ),
                ));
            }
        };
    }
    let (mut temp, mut dtemp) = (None, None);
    for (name, e) in params {
        match name.norm.as_str() {
            "area" => inst.area = positive_factor(e, "area", ctx.scope, element)?,
            "areab" => areab = Some(positive_factor(e, "areab", ctx.scope, element)?),
            "areac" => areac = Some(positive_factor(e, "areac", ctx.scope, element)?),
            "m" => inst.m = positive_factor(e, "multiplicity m", ctx.scope, element)?,
            "temp" => temp = Some(e),
            "dtemp" => dtemp = Some(e),
            "ic" | "icvbe" | "icvce" => {
                out.warnings.push(Warning::new(
                    name.pos,
                    name.orig.clone(),
                    format!(
                        "`{}` of `{}` ignored: initial conditions are set with `.ic` on nodes",
                        name.orig, element.orig
                    ),
                ));
            }
            _ => {
                return Err(NetlistError::new(
                    ErrorKind::Unsupported,
                    name.pos,
                    name.orig.clone(),
                    format!(
                        "BJT instance parameter `{}` of `{}` not supported (read: AREA, AREAB, \
                         AREAC, M, TEMP, DTEMP)",
                        name.orig, element.orig
                    ),
                ));
            }
        }
    }
    inst.areab = areab.unwrap_or(inst.area);
    inst.areac = areac.unwrap_or(inst.area);
    let temp = instance_temperature(temp, dtemp, ctx.scope, out.temperatures.0)?;
    let celsius = temp.unwrap_or(out.temperatures.0);
    let device = Bjt::at_temperature(&card, &inst, celsius).map_err(|e| {
        NetlistError::bad_value(
            element.pos,
            element.orig.clone(),
            format!("BJT `{}` (model `{}`): {e}", element.orig, model.orig),
        )
    })?;
    for w in &device.warnings {
        out.warnings.push(Warning::new(
            element.pos,
            element.orig.clone(),
            format!("BJT `{}`: {w}", element.orig),
        ));
    }
    let (collector, base, emitter) = (n(0), n(1), n(2));
    let substrate = substrate.map_or_else(|| "0".to_owned(), |s| ctx.node(s));
    let mut parts = Vec::new();
    let mut inner = |outer: &String, r: f64, which: &str, node: &str| {
        if r > 0.0 {
            let inner = crate::inner_name(&full, node);
            parts.push(Element::R {
                name: crate::inner_name(&full, which),
                n1: outer.clone(),
                n2: inner.clone(),
                value: r,
            });
            inner
        } else {
            outer.clone()
        }
    };
    let b = inner(&base, device.series[0], "rb", "base");
    let c = inner(&collector, device.series[1], "rc", "collector");
    let e = inner(&emitter, device.series[2], "re", "emitter");
    // The substrate junction (GMIN and CJS) from the substrate to the inner collector (vertical)
    // or base (lateral); not placed when the card's wiring shorts it. It carries no diode
    // current (ngspice-39's `ISS` is 0; a PNP base or an NPN collector below a grounded
    // substrate forward biases it on split supplies): its charge `CJS` only, as a junction that
    // does not conduct, and without `CJS` GMIN alone, a resistor.
    let contact = if card.vertical { &c } else { &b };
    if *contact != substrate {
        let (anode, cathode) = if device.substrate_anode {
            (substrate.clone(), contact.clone())
        } else {
            (contact.clone(), substrate.clone())
        };
        if device.substrate.cjo == 0.0 {
            parts.push(Element::R {
                name: crate::inner_name(&full, "sub"),
                n1: anode,
                n2: cathode,
                value: 1.0 / dirac_components::Diode::GMIN,
            });
        } else {
            parts.push(Element::D {
                name: crate::inner_name(&full, "sub"),
                anode,
                cathode,
                model: DiodeModel {
                    name: def.name.norm.clone(),
                    card: device.substrate,
                    tnom_given: true,
                    ignored: Vec::new(),
                    temp: Some(celsius),
                },
            });
        }
    }
    let core = Element::Controlled {
        name: full,
        n_plus: c,
        n_minus: e.clone(),
        source: ControlledSource::Bjt {
            base: b,
            emitter: e,
            core: Box::new(device.core),
        },
    };
    Ok((core, parts))
}

/// What an ignored `.model D` parameter would change (ngspice's level-1 diode and its
/// extensions).
fn unsupported_diode_parameter(name: &str) -> &'static str {
    match name {
        "level" => "only level 1 (the SPICE junction diode) is modelled",
        "kf" | "af" => "flicker noise: no effect on a transient or an operating point",
        "ikf" | "ik" | "ikr" => {
            "high-injection knee current: the forward (or reverse) current above it would grow \
             more slowly than exp(v/(N Vt)); here it does not"
        }
        "isr" | "nr" => {
            "recombination current: would add current at low forward bias (below about 0.4 V)"
        }
        "jsw" | "cjsw" | "cjp" | "vjsw" | "php" | "mjsw" | "fcs" | "pj" => {
            "sidewall (perimeter) current and capacitance: would add to IS and CJO"
        }
        "ibvl" | "nbvl" => "low-level breakdown current: would soften the breakdown knee",
        "tlev" | "tlevc" | "cta" | "ctp" | "tpb" | "tphp" | "xti_n" | "tbv1" | "tbv2" => {
            "an alternative temperature model (TLEV/TLEVC > 0): only the default (TLEV = 0) \
             temperature adjustment is modelled, so results away from TNOM may differ"
        }
        "rsw" | "jtun" | "jtunsw" | "ntun" | "xtitun" | "keg" => {
            "tunnelling or sidewall series resistance: would add reverse current or resistance"
        }
        "fv_max" | "bv_max" | "id_max" | "pd_max" | "te_max" => {
            "a safe-operating-area limit: ngspice only warns when it is exceeded"
        }
        "d" | "cond" | "dres" => "not a level-1 parameter",
        _ => "not a SPICE level-1 diode parameter; the simulation does not use it",
    }
}

fn expand(ctx: &Ctx<'_, '_>, out: &mut Out) -> Result<(), NetlistError> {
    for el in &ctx.block.elements {
        if !ctx.prefix.is_empty() {
            out.expanded += 1;
            if out.expanded > MAX_EXPANDED {
                return Err(NetlistError::new(
                    ErrorKind::Unsupported,
                    el.name.pos,
                    el.name.orig.clone(),
                    format!(
                        "subcircuit expansion creates more than {MAX_EXPANDED} elements (nested instances multiply) not supported"
                    ),
                ));
            }
        }
        let full = Ctx::join(&ctx.prefix, &el.name.norm);
        let orig = Ctx::join(&ctx.orig_prefix, &el.name.orig);
        if let ElemKind::X(sub, params) = &el.kind {
            out.claim(&full, &el.name, &orig, None)?;
            instantiate(ctx, el, sub, params, full, orig, out)?;
            continue;
        }
        let nodes: Vec<String> = el.nodes.iter().map(|n| ctx.node(n)).collect();
        let n = |i: usize| nodes.get(i).cloned().unwrap_or_default();
        let scope = ctx.scope;
        let index = out.elements.len();
        out.claim(&full, &el.name, &orig, Some(index))?;
        // The elements a device card places besides its main one (a MOSFET's junctions,
        // overlap capacitances and series resistances), named `"<card> <what>"`.
        let mut parts: Vec<Element> = Vec::new();
        let element = match &el.kind {
            ElemKind::R(v, instance) => {
                let value = scope.eval(v)?;
                if value == 0.0 {
                    return Err(NetlistError::bad_value(
                        v.pos,
                        v.text.clone(),
                        format!("resistance of `{}` must not be zero", el.name.orig),
                    ));
                }
                let factor = instance_factor(instance, scope, &el.name, out.temperatures)?;
                Element::R {
                    name: full,
                    n1: n(0),
                    n2: n(1),
                    value: value * factor / multiplicity(instance.m.as_ref(), scope, &el.name)?,
                }
            }
            ElemKind::L(v, ic, instance) => {
                let factor = instance_factor(instance, scope, &el.name, out.temperatures)?;
                if instance.m.is_some() || factor != 1.0 {
                    out.multiplied_inductors.insert(full.clone());
                }
                Element::L {
                    name: full,
                    n1: n(0),
                    n2: n(1),
                    value: scope.eval(v)? * factor
                        / multiplicity(instance.m.as_ref(), scope, &el.name)?,
                    ic: ic.as_ref().map(|e| scope.eval(e)).transpose()?,
                }
            }
            ElemKind::C(v, ic, instance) => Element::C {
                name: full,
                n1: n(0),
                n2: n(1),
                value: scope.eval(v)?
                    * instance_factor(instance, scope, &el.name, out.temperatures)?
                    * multiplicity(instance.m.as_ref(), scope, &el.name)?,
                ic: ic.as_ref().map(|e| scope.eval(e)).transpose()?,
            },
            ElemKind::V(f) => Element::V {
                name: full,
                n_plus: n(0),
                n_minus: n(1),
                source: source(f, scope, &mut out.warnings)?,
            },
            ElemKind::I(f) => Element::I {
                name: full,
                n_plus: n(0),
                n_minus: n(1),
                source: source(f, scope, &mut out.warnings)?,
            },
            ElemKind::K(l1, l2, k) => {
                let kv = scope.eval(k)?;
                if !(-1.0..=1.0).contains(&kv) {
                    return Err(NetlistError::bad_value(
                        k.pos,
                        k.text.clone(),
                        format!(
                            "coupling coefficient of `{}` must be in [-1, 1], got {kv}",
                            el.name.orig
                        ),
                    ));
                }
                if kv.abs() == 1.0 {
                    // L₁L₂ − M² = 0: the winding currents' inductance matrix is singular, and the
                    // step's Newton matrix with it (the run failed at its first step).
                    return Err(NetlistError::unsupported_in(
                        k.pos,
                        &k.text,
                        &format!(
                            "perfect coupling k = {kv} of `{}` (its inductance matrix is singular; \
                             |k| < 1 such as 0.999999 runs)",
                            el.name.orig
                        ),
                        &format!("{} {} {} {}", el.name.orig, l1.orig, l2.orig, k.text),
                    ));
                }
                if l1.norm == l2.norm {
                    return Err(NetlistError::bad_value(
                        l2.pos,
                        l2.orig.clone(),
                        format!("`{}` couples `{}` with itself", el.name.orig, l1.orig),
                    ));
                }
                let l1_full = Ctx::join(&ctx.prefix, &l1.norm);
                let l2_full = Ctx::join(&ctx.prefix, &l2.norm);
                out.krefs.push(KRef {
                    index,
                    l1: (l1_full.clone(), l1.clone()),
                    l2: (l2_full.clone(), l2.clone()),
                });
                Element::K {
                    name: full,
                    l1: l1_full,
                    l2: l2_full,
                    k: kv,
                }
            }
            ElemKind::D(model, instance) => {
                let (found_model, mscope) = ctx.model(model, "diode", &el.name)?;
                model_kind(found_model, &el.name, model, "diode", &[("d", ())])?;
                let mut model = diode_model(found_model, mscope, out)?;
                // The instance's area replaces the model's AREA; `m` multiplies either.
                let area = match &instance.area {
                    Some(e) => positive_factor(e, "area", scope, &el.name)?,
                    None => model.card.area,
                };
                model.card.area = area * multiplicity(instance.m.as_ref(), scope, &el.name)?;
                model.temp = instance_temperature(
                    instance.temp.as_ref(),
                    instance.dtemp.as_ref(),
                    scope,
                    out.temperatures.0,
                )?;
                Element::D {
                    name: full,
                    anode: n(0),
                    cathode: n(1),
                    model,
                }
            }
            ElemKind::M(model, params) => {
                let (channel, placed) =
                    mosfet_elements(ctx, &el.name, model, params, full, &nodes, out)?;
                parts = placed;
                channel
            }
            ElemKind::Q(words, params) => {
                let (core, placed) = bjt_elements(ctx, &el.name, words, params, full, &nodes, out)?;
                parts = placed;
                core
            }
            ElemKind::E(v) | ElemKind::G(v) => {
                let value = scope.eval(v)?;
                let (c_plus, c_minus) = (n(2), n(3));
                Element::Controlled {
                    name: full,
                    n_plus: n(0),
                    n_minus: n(1),
                    source: if matches!(el.kind, ElemKind::E(_)) {
                        ControlledSource::Vcvs {
                            c_plus,
                            c_minus,
                            gain: value,
                        }
                    } else {
                        ControlledSource::Vccs {
                            c_plus,
                            c_minus,
                            gm: value,
                        }
                    },
                }
            }
            ElemKind::F(control, v) | ElemKind::H(control, v) => {
                let value = scope.eval(v)?;
                let control_full = Ctx::join(&ctx.prefix, &control.norm);
                out.vrefs
                    .push((index, control_full.clone(), control.clone()));
                Element::Controlled {
                    name: full,
                    n_plus: n(0),
                    n_minus: n(1),
                    source: if matches!(el.kind, ElemKind::F(..)) {
                        ControlledSource::Cccs {
                            control: control_full,
                            gain: value,
                        }
                    } else {
                        ControlledSource::Ccvs {
                            control: control_full,
                            r: value,
                        }
                    },
                }
            }
            ElemKind::Behavioural(output, e) | ElemKind::Table(output, e, _) => {
                let mut controls = Vec::new();
                let read = expr::behavioural(&e.expr, scope, &mut |probe, pos| {
                    let sensing = match probe {
                        expr::Probe::Voltage(a, b) => {
                            let node = |n: &str| ctx.node(&Name::at(n, pos));
                            Sensing::Voltage {
                                plus: node(a),
                                minus: b.as_deref().map_or_else(|| "0".to_owned(), node),
                            }
                        }
                        expr::Probe::Current(c) => {
                            let source = Ctx::join(&ctx.prefix, c);
                            out.vrefs.push((index, source.clone(), Name::at(c, pos)));
                            Sensing::Current { source }
                        }
                    };
                    Ok(control_index(&mut controls, sensing))
                })?;
                let expression = match &el.kind {
                    ElemKind::Table(_, _, coordinates) => {
                        let values: Vec<f64> = coordinates
                            .iter()
                            .map(|c| scope.eval(c))
                            .collect::<Result<_, _>>()?;
                        let at = coordinates.first().map_or(el.name.pos, |c| c.pos);
                        expr::increasing(&values, at)?;
                        let points: Vec<(f64, f64)> =
                            values.chunks_exact(2).map(|p| (p[0], p[1])).collect();
                        match points.as_slice() {
                            // One pair is its y, as ngspice-39 makes it (a constant source).
                            [(_, y)] => Expression::Constant(*y),
                            _ => Expression::Table(Box::new(read), points),
                        }
                    }
                    _ => read,
                };
                Element::Controlled {
                    name: full,
                    n_plus: n(0),
                    n_minus: n(1),
                    source: ControlledSource::Behavioural {
                        output: *output,
                        controls,
                        expression,
                    },
                }
            }
            ElemKind::Poly(output, poly, coefficients) => {
                let controls: Vec<Sensing> = match poly {
                    PolyControls::Nodes(count) => (0..*count)
                        .map(|k| Sensing::Voltage {
                            plus: n(2 + 2 * k),
                            minus: n(3 + 2 * k),
                        })
                        .collect(),
                    PolyControls::Sources(names) => names
                        .iter()
                        .map(|c| {
                            let source = Ctx::join(&ctx.prefix, &c.norm);
                            out.vrefs.push((index, source.clone(), c.clone()));
                            Sensing::Current { source }
                        })
                        .collect(),
                };
                let values = coefficients
                    .iter()
                    .map(|c| scope.eval(c))
                    .collect::<Result<Vec<f64>, _>>()?;
                Element::Controlled {
                    name: full,
                    n_plus: n(0),
                    n_minus: n(1),
                    source: ControlledSource::Behavioural {
                        output: *output,
                        expression: polynomial(controls.len(), &values),
                        controls,
                    },
                }
            }
            ElemKind::X(..) => continue,
        };
        for element in std::iter::once(element).chain(parts.drain(..)) {
            if out.elements.len() > index {
                out.claim(element.name(), &el.name, &orig, Some(out.elements.len()))?;
            }
            out.elements.push(element);
            out.origins.push(Origin {
                name: orig.clone(),
                line: el.name.pos.line,
                column: el.name.pos.column,
                file: String::new(),
                file_index: el.name.pos.file,
            });
        }
    }
    for (node, e) in &ctx.block.ics {
        let v = ctx.scope.eval(e)?;
        out.ics.push((ctx.node(node), v, node.clone()));
    }
    Ok(())
}

/// The index of `sensing` among a behavioural source's `controls`, added if new (a quantity read
/// twice is sensed once).
fn control_index(controls: &mut Vec<Sensing>, sensing: Sensing) -> usize {
    match controls.iter().position(|c| *c == sensing) {
        Some(k) => k,
        None => {
            controls.push(sensing);
            controls.len() - 1
        }
    }
}

/// SPICE's `POLY(n)` with `coefficients` `p₀, p₁, …`: `p₀`, then the terms of each degree in turn,
/// each a product `x_{i₁}·…·x_{i_d}` over the index tuples `i₁ ≤ … ≤ i_d` in lexicographic order
/// (`POLY(2)`: `p₀ + p₁x₁ + p₂x₂ + p₃x₁² + p₄x₁x₂ + p₅x₂² + p₆x₁³ + …`), as ngspice-39 evaluates
/// it (a single coefficient is `p₀`). Zero coefficients add no term.
fn polynomial(n: usize, coefficients: &[f64]) -> Expression {
    let mut sum = Expression::Constant(coefficients.first().copied().unwrap_or(0.0));
    let mut term: Vec<usize> = Vec::new();
    for &c in coefficients.iter().skip(1) {
        next_monomial(&mut term, n);
        if c == 0.0 {
            continue;
        }
        let product = term.iter().fold(Expression::Constant(c), |acc, &k| {
            Expression::Binary(
                Operator::Mul,
                Box::new(acc),
                Box::new(Expression::Control(k)),
            )
        });
        sum = Expression::Binary(Operator::Add, Box::new(sum), Box::new(product));
    }
    sum
}

/// The monomial after `term` (nondecreasing indices below `n`) in SPICE's order: the next tuple
/// of the same degree in lexicographic order, or the first of the next degree.
fn next_monomial(term: &mut Vec<usize>, n: usize) {
    // The last position that can still grow; the ones after it restart at its new value.
    match (0..term.len()).rev().find(|&j| term[j] + 1 < n) {
        Some(j) => {
            let v = term[j] + 1;
            for t in &mut term[j..] {
                *t = v;
            }
        }
        None => {
            let degree = term.len() + 1;
            term.clear();
            term.resize(degree, 0);
        }
    }
}

fn instantiate(
    ctx: &Ctx<'_, '_>,
    el: &super::parser::ElemCard,
    sub: &Name,
    params: &[(Name, ExprTok)],
    full: String,
    orig: String,
    out: &mut Out,
) -> Result<(), NetlistError> {
    let mut found = None;
    let mut c = Some(ctx);
    while let Some(cx) = c {
        if let Some(d) = cx.block.subckts.iter().find(|d| d.name.norm == sub.norm) {
            found = Some(d);
            break;
        }
        c = cx.parent;
    }
    let Some(def) = found else {
        return Err(NetlistError::new(
            ErrorKind::UnknownSubckt,
            sub.pos,
            sub.orig.clone(),
            format!(
                "`{}` instantiates undefined subcircuit `{}`",
                el.name.orig, sub.orig
            ),
        ));
    };
    let mut c = Some(ctx);
    let mut levels = 0;
    while let Some(cx) = c {
        levels += 1;
        if levels > MAX_SUBCKT_DEPTH {
            return Err(NetlistError::new(
                ErrorKind::Unsupported,
                sub.pos,
                sub.orig.clone(),
                format!(
                    "subcircuits nested more than {MAX_SUBCKT_DEPTH} levels deep not supported"
                ),
            ));
        }
        if cx.def.is_some_and(|d| std::ptr::eq(d, def)) {
            return Err(NetlistError::new(
                ErrorKind::RecursiveSubckt,
                sub.pos,
                sub.orig.clone(),
                format!(
                    "`{}` instantiates subcircuit `{}` inside itself",
                    el.name.orig, def.name.orig
                ),
            ));
        }
        c = cx.parent;
    }
    if el.nodes.len() != def.ports.len() {
        return Err(NetlistError::new(
            ErrorKind::PortMismatch,
            sub.pos,
            sub.orig.clone(),
            format!(
                "`{}` connects {} node{} but subcircuit `{}` has {} port{}",
                el.name.orig,
                el.nodes.len(),
                if el.nodes.len() == 1 { "" } else { "s" },
                def.name.orig,
                def.ports.len(),
                if def.ports.len() == 1 { "" } else { "s" },
            ),
        ));
    }
    let scope = Scope::new(Some(ctx.scope));
    scope.define_functions(&def.body.funcs);
    for (name, e) in &def.defaults {
        scope.define(&name.norm, Slot::Pending(e.clone()));
    }
    for (name, e) in params {
        if !def.defaults.iter().any(|(d, _)| d.norm == name.norm) {
            return Err(NetlistError::new(
                ErrorKind::UnknownParam,
                name.pos,
                name.orig.clone(),
                format!(
                    "subcircuit `{}` has no parameter `{}`",
                    def.name.orig, name.orig
                ),
            ));
        }
        let v = ctx.scope.eval(e)?;
        scope.define(&name.norm, Slot::Value(v));
    }
    for (name, e) in &def.body.params {
        scope.define(&name.norm, Slot::Pending(e.clone()));
    }
    for (p, n) in def.ports.iter().zip(&el.nodes) {
        let actual = ctx.node(n);
        if p.norm == "0" && actual != "0" {
            out.warnings.push(Warning::new(
                n.pos,
                n.orig.clone(),
                format!(
                    "port `{}` of subcircuit `{}` is the ground node, as in ngspice: node `{}` \
                     that `{}` connects to it is not connected to the subcircuit",
                    p.orig, def.name.orig, n.orig, el.name.orig
                ),
            ));
        }
    }
    let ports = def
        .ports
        .iter()
        .zip(&el.nodes)
        .filter(|(p, _)| p.norm != "0")
        .map(|(p, n)| (p.norm.clone(), ctx.node(n)))
        .collect();
    let inner = Ctx {
        block: &def.body,
        scope: &scope,
        parent: Some(ctx),
        prefix: full,
        orig_prefix: orig,
        ports,
        def: Some(def),
        globals: ctx.globals,
    };
    expand(&inner, out)
}

/// An R, L, C or D card's `m=` (that many equal elements in parallel, as ngspice reads it: R and
/// L divided by it, C and a diode's area multiplied), 1 when absent.
fn multiplicity(
    m: Option<&ExprTok>,
    scope: &Scope<'_>,
    element: &Name,
) -> Result<f64, NetlistError> {
    m.map_or(Ok(1.0), |e| {
        positive_factor(e, "multiplicity m", scope, element)
    })
}

/// The factor an R, L or C card's instance parameters put on its value (besides `m`): `scale`
/// times ngspice's temperature factor at the instance temperature `T` (`temp=`, else the
/// circuit's plus `dtemp=`; ngspice ignores `dtemp` when `temp` is given) against `TNOM`:
/// `1.01^(tce·ΔT)` with `tce`, else `1 + tc1·ΔT + tc2·ΔT²` (`restemp.c`, `captemp.c`,
/// `indtemp.c`). `temperatures` is the circuit's `(temp, tnom)` in °C.
fn instance_factor(
    instance: &super::parser::Instance,
    scope: &Scope<'_>,
    element: &Name,
    temperatures: (f64, f64),
) -> Result<f64, NetlistError> {
    let value = |e: &Option<ExprTok>| e.as_ref().map(|e| scope.eval(e)).transpose();
    let scale = instance
        .scale
        .as_ref()
        .map_or(Ok(1.0), |e| positive_factor(e, "scale", scope, element))?;
    let (circuit, tnom) = temperatures;
    let temperature = instance_temperature(
        instance.temp.as_ref(),
        instance.dtemp.as_ref(),
        scope,
        circuit,
    )?
    .unwrap_or(circuit);
    let difference = temperature - tnom;
    let factor = match value(&instance.tce)? {
        Some(tce) => 1.01_f64.powf(tce * difference),
        None => {
            let (tc1, tc2) = (value(&instance.tc1)?, value(&instance.tc2)?);
            1.0 + (tc2.unwrap_or(0.0) * difference + tc1.unwrap_or(0.0)) * difference
        }
    };
    if factor > 0.0 && factor.is_finite() {
        Ok(scale * factor)
    } else {
        Err(NetlistError::bad_value(
            element.pos,
            element.orig.clone(),
            format!(
                "`{}`: its temperature coefficients give the factor {factor} at {temperature} °C \
                 (TNOM {tnom} °C); it must be positive",
                element.orig
            ),
        ))
    }
}

/// The circuit's temperature and `TNOM` in °C from the options (a `.temp` card is the option
/// `temp`; the last value counts), 27 °C each by default. A value that is not a number is left
/// at its default here: the circuit builder reports it at its card.
fn temperatures(options: &[super::OptionCard]) -> (f64, f64) {
    let mut out = (27.0, 27.0);
    for option in options {
        let value = option.value.as_deref().and_then(super::parse_spice_number);
        match (option.key.as_str(), value) {
            ("temp", Some(t)) => out.0 = t,
            ("tnom", Some(t)) => out.1 = t,
            _ => {}
        }
    }
    out
}

/// A MOSFET's default geometry from `.options defl defw defad defas` (ngspice's names; 100 µm,
/// 100 µm, 0, 0 otherwise). A value out of range is left at its default here: the circuit
/// builder reports it at its card.
fn mos_defaults(options: &[super::OptionCard]) -> MosfetGeometry {
    let mut g = MosfetGeometry::default();
    for option in options {
        let key = option.key.as_str();
        let Some(v) = option
            .value
            .as_deref()
            .and_then(super::parse_spice_number)
            .filter(|&v| mos_default_check(key, v) == Some(Ok(())))
        else {
            continue;
        };
        match key {
            "defl" => g.l = v,
            "defw" => g.w = v,
            "defad" => g.ad = v,
            _ => g.as_ = v,
        }
    }
    g
}

/// Whether `value` may set the MOSFET geometry default `.options key`: `Ok`, or the
/// requirement it misses in words (`defl`, `defw` must be positive, `defad`, `defas` must not
/// be negative); `None` for another key.
pub(crate) fn mos_default_check(key: &str, value: f64) -> Option<Result<(), &'static str>> {
    let (holds, requirement) = match key {
        "defl" | "defw" => (value > 0.0, "must be positive"),
        "defad" | "defas" => (value >= 0.0, "must not be negative"),
        _ => return None,
    };
    Some(if holds { Ok(()) } else { Err(requirement) })
}

/// The value of `e`, a scale factor (`what`) of `element` that must be positive and finite.
fn positive_factor(
    e: &ExprTok,
    what: &str,
    scope: &Scope<'_>,
    element: &Name,
) -> Result<f64, NetlistError> {
    let value = scope.eval(e)?;
    if value > 0.0 && value.is_finite() {
        Ok(value)
    } else {
        Err(NetlistError::bad_value(
            e.pos,
            e.text.clone(),
            format!("{what} of `{}` must be positive, got {value}", element.orig),
        ))
    }
}

/// Warnings for a `.tran` whose TSTOP or TSTART is not a whole number of TSTEPs: dirac steps
/// on the grid `k·TSTEP`, so its last row is at `round(TSTOP/TSTEP)·TSTEP` and its first at the
/// first grid time from TSTART, where ngspice ends at TSTOP and starts its output at TSTART.
fn off_grid_warnings(t: &Tran, card: &TranCard, warnings: &mut Vec<Warning>) {
    let off = |x: f64| {
        let r = x / t.tstep;
        (r - r.round()).abs() > 1e-9 * r.max(1.0)
    };
    let at = |i: usize| card.values.get(i).map(|e| (e.pos, e.text.clone()));
    if off(t.tstop)
        && let Some((pos, text)) = at(1)
    {
        let end = (t.tstop / t.tstep).round() * t.tstep;
        warnings.push(Warning::new(
            pos,
            text,
            format!(
                "TSTOP = {} is not a whole number of TSTEP = {} steps: the fixed-step run ends at \
                 {end:.6e} (ngspice ends at TSTOP); choose a TSTEP that divides TSTOP, or set --h",
                t.tstop, t.tstep
            ),
        ));
    }
    if t.tstart > 0.0
        && off(t.tstart)
        && let Some((pos, text)) = at(2)
    {
        let first = (t.tstart / t.tstep).ceil() * t.tstep;
        warnings.push(Warning::new(
            pos,
            text,
            format!(
                "TSTART = {} is not on the TSTEP = {} grid: the first row is at {first:.6e}",
                t.tstart, t.tstep
            ),
        ));
    }
}

fn tran(parsed: &Parsed, scope: &Scope<'_>) -> Result<Option<Tran>, NetlistError> {
    let Some(card) = &parsed.tran else {
        return Ok(None);
    };
    let v: Vec<f64> = card
        .values
        .iter()
        .map(|e| scope.eval(e))
        .collect::<Result<_, _>>()?;
    let bad = |i: usize, what: &str| {
        let e = &card.values[i];
        NetlistError::bad_value(
            e.pos,
            e.text.clone(),
            format!("`.tran` {what}, got `{}` = {}", e.text, v[i]),
        )
    };
    let tstep = v[0];
    let tstop = v[1];
    if tstep <= 0.0 {
        return Err(bad(0, "TSTEP must be positive"));
    }
    if tstop <= 0.0 {
        return Err(bad(1, "TSTOP must be positive"));
    }
    let tstart = v.get(2).copied().unwrap_or(0.0);
    if v.len() > 2 && !(0.0..tstop).contains(&tstart) {
        return Err(bad(2, "TSTART must be in [0, TSTOP)"));
    }
    // A TMAX of 0 is no TMAX, as ngspice reads it.
    let tmax = v.get(3).copied().filter(|&t| t != 0.0);
    if let Some(t) = tmax
        && (t < 0.0 || !t.is_finite())
    {
        return Err(bad(3, "TMAX must be positive (or 0: none)"));
    }
    Ok(Some(Tran {
        tstep,
        tstop,
        tstart,
        tmax,
        uic: card.uic,
    }))
}

/// Expands subcircuits and evaluates parameters.
pub(crate) fn flatten(mut parsed: Parsed, set: &[(String, f64)]) -> Result<Netlist, NetlistError> {
    let global = Scope::new(None);
    global.temperature.set(temperatures(&parsed.options).0);
    global.define_functions(&parsed.top.funcs);
    for (name, e) in &parsed.top.params {
        let given = set
            .iter()
            .rev()
            .find(|(n, _)| n.eq_ignore_ascii_case(&name.norm));
        global.define(
            &name.norm,
            given.map_or_else(|| Slot::Pending(e.clone()), |&(_, v)| Slot::Value(v)),
        );
    }
    let mut out = Out {
        warnings: parsed.warnings.clone(),
        temperatures: temperatures(&parsed.options),
        mos_defaults: mos_defaults(&parsed.options),
        instance_values: set
            .iter()
            .filter(|(n, _)| n.contains('.'))
            .map(|(n, v)| (n.to_ascii_lowercase(), *v))
            .collect(),
        ..Out::default()
    };
    let globals: HashSet<String> = parsed.globals.iter().cloned().collect();
    let root = Ctx {
        block: &parsed.top,
        scope: &global,
        parent: None,
        prefix: String::new(),
        orig_prefix: String::new(),
        ports: HashMap::new(),
        def: None,
        globals: &globals,
    };
    expand(&root, &mut out)?;
    // Evaluate the top-level parameters nobody used, so their errors are not hidden.
    let mut parameters: Vec<(String, f64)> = Vec::new();
    for (name, _) in &parsed.top.params {
        let value = global.lookup(&name.norm, name.pos)?;
        match parameters.iter_mut().find(|(n, _)| *n == name.norm) {
            Some(entry) => entry.1 = value,
            None => parameters.push((name.norm.clone(), value)),
        }
    }
    let tran = tran(&parsed, &global)?;
    let measures = std::mem::take(&mut parsed.measures)
        .into_iter()
        .map(|m| m.try_map(&mut |e| global.eval(&e)))
        .collect::<Result<Vec<_>, _>>()?;
    if let (Some(t), Some(card)) = (&tran, &parsed.tran) {
        off_grid_warnings(t, card, &mut out.warnings);
    }

    for k in &out.krefs {
        let kname = out
            .origins
            .get(k.index)
            .map(|o| o.name.clone())
            .unwrap_or_default();
        for (full, name) in [&k.l1, &k.l2] {
            let is_inductor = matches!(
                out.names.get(full),
                Some(Some(i)) if matches!(out.elements.get(*i), Some(Element::L { .. }))
            );
            if !is_inductor {
                return Err(NetlistError::new(
                    ErrorKind::UnknownElement,
                    name.pos,
                    name.orig.clone(),
                    format!(
                        "`{kname}` couples `{}`, which is not an inductor",
                        name.orig
                    ),
                ));
            }
            if out.multiplied_inductors.contains(full) {
                // ngspice divides the self-inductance by `m` but not the `L` in M = k√(L₁L₂):
                // a mutual inductance no physical winding has. Refused rather than guessed, and
                // so is a scale or temperature factor on a coupled winding.
                return Err(NetlistError::unsupported_in(
                    name.pos,
                    &name.orig,
                    &format!(
                        "a coupled inductor written with `m=`, `scale=` or a temperature factor \
                         (`{}`)",
                        name.orig
                    ),
                    &format!("{kname} {} {}", k.l1.1.orig, k.l2.1.orig),
                ));
            }
        }
    }

    for (index, full, name) in &out.vrefs {
        // A voltage source: independent, or the output of an E or H source (ngspice reads those
        // branch currents too; an inductor's it refuses).
        let found = out.names.get(full);
        if matches!(found, Some(Some(i)) if match out.elements.get(*i) {
            Some(Element::V { .. }) => true,
            Some(Element::Controlled { source, .. }) => source.drives_voltage(),
            _ => false,
        }) {
            continue;
        }
        let element = out
            .origins
            .get(*index)
            .map(|o| o.name.clone())
            .unwrap_or_default();
        let why = match found {
            Some(_) => "which is not a voltage source (V, E, H, or B with V=)".to_owned(),
            None if full.contains('.') && out.names.contains_key(&name.norm) => format!(
                "which its subcircuit does not have (names in F, H and B cards are local to the \
                 subcircuit, as in ngspice; the top-level `{}` is not seen there)",
                name.orig
            ),
            None => "but no element has that name".to_owned(),
        };
        return Err(NetlistError::new(
            ErrorKind::UnknownElement,
            name.pos,
            name.orig.clone(),
            format!(
                "`{element}` is controlled by the current of `{}`, {why}",
                name.orig
            ),
        ));
    }

    let mut nodes: HashSet<&str> = HashSet::new();
    for e in &out.elements {
        nodes.extend(e.nodes());
    }
    let mut ic: Vec<(String, f64)> = Vec::new();
    for (node, v, name) in &out.ics {
        if node == "0" || !nodes.contains(node.as_str()) {
            return Err(NetlistError::new(
                ErrorKind::UnknownNode,
                name.pos,
                name.orig.clone(),
                if node == "0" {
                    "`.ic` on the ground node".to_owned()
                } else {
                    format!(
                        "`.ic` names node `{}` that no element connects to",
                        name.orig
                    )
                },
            ));
        }
        if let Some(slot) = ic.iter_mut().find(|(n, _)| n == node) {
            out.warnings.push(Warning::new(
                name.pos,
                name.orig.clone(),
                format!(
                    "second `.ic` for node `{}`; the last one is used",
                    name.orig
                ),
            ));
            slot.1 = *v;
        } else {
            ic.push((node.clone(), *v));
        }
    }

    let mut elements = out.elements;
    if let Some(t) = &tran {
        for e in &mut elements {
            if let Element::V { source, .. } | Element::I { source, .. } = e {
                *source = source.resolved(t.tstep, t.tstop);
            }
        }
    }

    let mut seen = HashSet::new();
    let mut warnings: Vec<Warning> = out
        .warnings
        .into_iter()
        .filter(|w| seen.insert((w.file_index, w.line, w.column, w.message.clone())))
        .collect();
    warnings.sort_by_key(|w| (w.file_index, w.line, w.column));

    Ok(Netlist {
        title: parsed.title,
        elements,
        origins: out.origins,
        tran,
        ic,
        op: parsed.op,
        options: parsed.options,
        outputs: parsed.outputs,
        measures,
        parameters,
        warnings,
        files: Vec::new(),
    })
}
