//! Reading a scene file: TOML → [`Scene`], every error with `file:line:column`.
//!
//! The document is parsed once into toml's spanned tree ([`DeTable`]). Tables whose meaning
//! depends on a `type` key (parts, connections, coupling elements) are dispatched by hand on that
//! key and the rest of the table is handed to the parameter struct of that type through
//! [`ValueDeserializer`], so unknown keys and wrong types are reported at the exact key or value
//! (serde's own internally tagged enums would buffer the table and lose every position inside it).

use std::cell::Cell;
use std::collections::BTreeMap;
use std::ops::Range;
use std::sync::Arc;

use serde::Deserialize;
use toml::Spanned;
use toml::de::{DeTable, DeValue, ValueDeserializer};

use super::error::{Location, Origin, SceneError, listed};
use super::model::{
    Connection, ConnectionKind, ELEMENT_TYPES, ElementSpec, PART_TYPES, Part, PartKind,
    RIGID_JOINT_TYPES, Record, RigidJointSpec, Scene, Simulation,
};

/// Positions of values and keys inside an item, by path.
#[derive(Default)]
struct Positions {
    values: BTreeMap<String, (usize, usize)>,
    keys: BTreeMap<String, (usize, usize)>,
}

/// The source text and its name, for turning byte offsets into line and column.
struct Source<'a> {
    text: &'a str,
    file: Arc<str>,
    /// Byte offset of the start of every line.
    lines: Vec<usize>,
    /// The last offset turned into a column, and that column (0-based): positions are looked up
    /// in increasing order, so counting on from there keeps a line of n values linear in n
    /// rather than quadratic (a converted netlist's node of 10⁴ ports is one line).
    cursor: Cell<(usize, usize)>,
}

impl<'a> Source<'a> {
    fn new(text: &'a str, file: &str) -> Self {
        let mut lines = vec![0];
        lines.extend(text.match_indices('\n').map(|(i, _)| i + 1));
        Self {
            text,
            file: file.into(),
            lines,
            cursor: Cell::new((0, 0)),
        }
    }

    /// 1-based line and column (in characters) of byte offset `offset`.
    fn line_column(&self, offset: usize) -> (usize, usize) {
        let offset = offset.min(self.text.len());
        let line = self.lines.partition_point(|&start| start <= offset);
        let start = self.lines[line - 1];
        let (last, last_column) = self.cursor.get();
        let (from, before) = if start <= last && last <= offset {
            (last, last_column)
        } else {
            (start, 0)
        };
        let column = self
            .text
            .get(from..offset)
            .map_or_else(|| offset - start, |s| before + s.chars().count());
        self.cursor.set((offset, column));
        (line, column + 1)
    }

    fn location(&self, span: &Range<usize>) -> Location {
        let (line, column) = self.line_column(span.start);
        Location {
            file: self.file.to_string(),
            line,
            column,
        }
    }

    fn error(&self, span: &Range<usize>, message: impl Into<String>) -> SceneError {
        SceneError::Toml {
            at: self.location(span),
            message: message.into(),
        }
    }

    /// A toml/serde error; without a span of its own it is placed at `fallback`.
    fn toml_error(&self, e: &toml::de::Error, fallback: &Range<usize>) -> SceneError {
        let span = e.span().unwrap_or_else(|| fallback.clone());
        self.error(&span, e.message().trim_end())
    }

    /// Deserialises `value` into `T`, errors placed at the offending key or value.
    fn de<T: for<'de> Deserialize<'de>>(
        &self,
        value: Spanned<DeValue<'_>>,
    ) -> Result<T, SceneError> {
        let span = value.span();
        T::deserialize(ValueDeserializer::from(value)).map_err(|e| self.toml_error(&e, &span))
    }

    /// The origin of an item: its position and the position of every value inside it.
    fn origin(&self, span: &Range<usize>, table: &DeTable<'_>) -> Origin {
        let mut positions = Positions::default();
        for (k, v) in table.iter() {
            let path = k.get_ref().to_string();
            positions
                .keys
                .insert(path.clone(), self.line_column(k.span().start));
            self.record(&mut positions, path, v);
        }
        Origin::new(
            self.file.clone(),
            self.line_column(span.start),
            positions.values,
            positions.keys,
        )
    }

    fn record(&self, positions: &mut Positions, path: String, value: &Spanned<DeValue<'_>>) {
        // The value's own position first: positions are then looked up in text order.
        let here = self.line_column(value.span().start);
        match value.get_ref() {
            DeValue::Table(t) => {
                for (k, v) in t.iter() {
                    let inner = format!("{path}.{}", k.get_ref());
                    positions
                        .keys
                        .insert(inner.clone(), self.line_column(k.span().start));
                    self.record(positions, inner, v);
                }
            }
            DeValue::Array(a) => {
                for (i, v) in a.iter().enumerate() {
                    self.record(positions, format!("{path}[{i}]"), v);
                }
            }
            _ => {}
        }
        positions.values.insert(path, here);
    }
}

/// Parses scene text read from `file` (the name used in error messages) and checks it: every
/// part, port, coordinate and signal it names must exist and every parameter must be in range.
pub fn parse_scene(text: &str, file: &str) -> Result<Scene, SceneError> {
    let scene = parse_unchecked(text, file)?;
    scene.build()?;
    Ok(scene)
}

/// Parses without the semantic checks of [`parse_scene`].
pub(crate) fn parse_unchecked(text: &str, file: &str) -> Result<Scene, SceneError> {
    let src = Source::new(text, file);
    let root = DeTable::parse(text).map_err(|e| src.toml_error(&e, &(0..0)))?;
    let root_span = root.span();
    let mut table = root.into_inner();
    const TOP: [&str; 4] = ["simulation", "part", "connection", "record"];
    if let Some((k, _)) = table
        .iter()
        .find(|(k, _)| !TOP.contains(&k.get_ref().as_ref()))
    {
        return Err(src.error(
            &k.span(),
            format!(
                "unknown key `{}`, expected one of {}",
                k.get_ref(),
                listed(TOP)
            ),
        ));
    }
    let simulation = match table.remove("simulation") {
        Some(v) => {
            let span = v.span();
            let origin = match v.get_ref() {
                DeValue::Table(t) => src.origin(&span, t),
                _ => Origin::default(),
            };
            let mut s: Simulation = src.de(v)?;
            s.origin = origin;
            s
        }
        None => {
            return Err(src.error(
                &(root_span.start..root_span.start),
                "missing table `[simulation]` (it needs at least `h` and `t_end`)",
            ));
        }
    };
    let parts = array_of_tables(&src, table.remove("part"), "part")?
        .into_iter()
        .map(|(span, t)| parse_part(&src, span, t))
        .collect::<Result<Vec<_>, _>>()?;
    let connections = array_of_tables(&src, table.remove("connection"), "connection")?
        .into_iter()
        .map(|(span, t)| parse_connection(&src, span, t))
        .collect::<Result<Vec<_>, _>>()?;
    let record = match table.remove("record") {
        Some(v) => {
            let span = v.span();
            let origin = match v.get_ref() {
                DeValue::Table(t) => src.origin(&span, t),
                _ => Origin::default(),
            };
            let mut r: Record = src.de(v)?;
            r.origin = origin;
            r
        }
        None => Record::default(),
    };
    Ok(Scene {
        simulation,
        parts,
        connections,
        record,
    })
}

/// The tables of `[[key]]`.
fn array_of_tables<'i>(
    src: &Source<'_>,
    value: Option<Spanned<DeValue<'i>>>,
    key: &str,
) -> Result<Vec<(Range<usize>, DeTable<'i>)>, SceneError> {
    let Some(value) = value else {
        return Ok(Vec::new());
    };
    let span = value.span();
    let DeValue::Array(items) = value.into_inner() else {
        return Err(src.error(
            &span,
            format!("`{key}` must be an array of tables: write each one under `[[{key}]]`"),
        ));
    };
    items
        .into_iter()
        .map(|item| {
            let span = item.span();
            match item.into_inner() {
                DeValue::Table(t) => Ok((span, t)),
                _ => Err(src.error(
                    &span,
                    format!("each `{key}` must be a table: write it under `[[{key}]]`"),
                )),
            }
        })
        .collect()
}

/// Removes `key` from `table` and deserialises it; `None` when absent.
fn take<T: for<'de> Deserialize<'de>>(
    src: &Source<'_>,
    table: &mut DeTable<'_>,
    key: &str,
) -> Result<Option<T>, SceneError> {
    table.remove(key).map(|v| src.de(v)).transpose()
}

/// Removes the required string `key` from `table`: its value and span.
fn take_string(
    src: &Source<'_>,
    table: &mut DeTable<'_>,
    key: &str,
    item: &str,
    span: &Range<usize>,
) -> Result<(String, Range<usize>), SceneError> {
    match table.remove(key) {
        Some(v) => {
            let vspan = v.span();
            Ok((src.de::<String>(v)?, vspan))
        }
        None => Err(src.error(span, format!("{item} is missing the key `{key}`"))),
    }
}

/// Deserialises the remaining keys of a typed table into its parameter struct. An unknown key is
/// reported with the keys every such table has besides its parameters.
fn params<T: for<'de> Deserialize<'de>>(
    src: &Source<'_>,
    span: &Range<usize>,
    table: DeTable<'_>,
    common: &str,
) -> Result<T, SceneError> {
    let keys: Vec<String> = table
        .iter()
        .map(|(k, _)| format!("`{}`", k.get_ref()))
        .collect();
    src.de(Spanned::new(span.clone(), DeValue::Table(table)))
        .map_err(|e| match e {
            // An unknown key of this table (not of a table nested in it): say which keys every
            // such table has besides its parameters.
            SceneError::Toml { at, message }
                if message.starts_with("unknown field")
                    && keys
                        .iter()
                        .any(|k| message.starts_with(&format!("unknown field {k}"))) =>
            {
                SceneError::Toml {
                    at,
                    message: format!("{message} (or {common})"),
                }
            }
            other => other,
        })
}

fn parse_part(
    src: &Source<'_>,
    span: Range<usize>,
    mut t: DeTable<'_>,
) -> Result<Part, SceneError> {
    let origin = src.origin(&span, &t);
    let (type_name, type_span) = take_string(src, &mut t, "type", "a part", &span)?;
    let (name, _) = take_string(src, &mut t, "name", "a part", &span)?;
    let q0 = take(src, &mut t, "q0")?;
    let v0 = take(src, &mut t, "v0")?;
    let common = "`name`, `type`, `q0`, `v0`";
    let kind = match type_name.as_str() {
        "resistor" => PartKind::Resistor(params(src, &span, t, common)?),
        "inductor" => PartKind::Inductor(params(src, &span, t, common)?),
        "capacitor" => PartKind::Capacitor(params(src, &span, t, common)?),
        "voltage_source" => PartKind::VoltageSource(params(src, &span, t, common)?),
        "current_source" => PartKind::CurrentSource(params(src, &span, t, common)?),
        "coupled_inductors" => PartKind::CoupledInductors(params(src, &span, t, common)?),
        "diode" => PartKind::Diode(params(src, &span, t, common)?),
        "saturating_inductor" => PartKind::SaturatingInductor(params(src, &span, t, common)?),
        "mass" => PartKind::Mass(params(src, &span, t, common)?),
        "inertia" => PartKind::Inertia(params(src, &span, t, common)?),
        "spring" => PartKind::Spring(params(src, &span, t, common)?),
        "damper" => PartKind::Damper(params(src, &span, t, common)?),
        "force_source" => PartKind::ForceSource(params(src, &span, t, common)?),
        "ground" => PartKind::Ground(params(src, &span, t, common)?),
        "pendulum" => PartKind::Pendulum(params(src, &span, t, common)?),
        "planar_linkage" => PartKind::PlanarLinkage(params(src, &span, t, common)?),
        "dc_motor" => PartKind::DcMotor(params(src, &span, t, common)?),
        "ideal_transformer" => PartKind::IdealTransformer(params(src, &span, t, common)?),
        "ideal_gear" => PartKind::IdealGear(params(src, &span, t, common)?),
        "rolling_disk" => PartKind::RollingDisk(params(src, &span, t, common)?),
        "rigid_body" => PartKind::RigidBody(params(src, &span, t, common)?),
        "vcvs" => PartKind::Vcvs(params(src, &span, t, common)?),
        "vccs" => PartKind::Vccs(params(src, &span, t, common)?),
        "cccs" => PartKind::Cccs(params(src, &span, t, common)?),
        "ccvs" => PartKind::Ccvs(params(src, &span, t, common)?),
        other => {
            return Err(SceneError::UnknownPartType {
                at: Some(src.location(&type_span)),
                type_name: other.to_string(),
                expected: listed(PART_TYPES),
            });
        }
    };
    Ok(Part {
        name,
        kind,
        q0,
        v0,
        origin,
    })
}

fn parse_connection(
    src: &Source<'_>,
    span: Range<usize>,
    mut t: DeTable<'_>,
) -> Result<Connection, SceneError> {
    let origin = src.origin(&span, &t);
    let (type_name, type_span) = take_string(src, &mut t, "type", "a connection", &span)?;
    let (name, _) = take_string(src, &mut t, "name", "a connection", &span)?;
    #[derive(Deserialize)]
    #[serde(deny_unknown_fields)]
    struct NodeKeys {
        ports: Vec<super::model::NodePort>,
    }
    #[derive(Deserialize)]
    #[serde(deny_unknown_fields)]
    struct JointKeys {
        a: String,
        b: String,
    }
    let common = "`name`, `type`";
    let kind = match type_name.as_str() {
        "node" => {
            let keys: NodeKeys = params(src, &span, t, common)?;
            ConnectionKind::Node { ports: keys.ports }
        }
        "joint" => {
            let keys: JointKeys = params(src, &span, t, common)?;
            ConnectionKind::Joint {
                a: keys.a,
                b: keys.b,
            }
        }
        "coupling" => {
            let element = match t.remove("element") {
                Some(v) => parse_element(src, v)?,
                None => {
                    return Err(src.error(
                        &span,
                        format!("coupling `{name}` is missing the key `element`"),
                    ));
                }
            };
            let keys: JointKeys = params(src, &span, t, "`name`, `type`, `element`")?;
            ConnectionKind::Coupling {
                a: keys.a,
                b: keys.b,
                element,
            }
        }
        "joint_coordinate" => {
            #[derive(Deserialize)]
            #[serde(deny_unknown_fields)]
            struct CoordinateKeys {
                joint: String,
                port: String,
            }
            let keys: CoordinateKeys = params(src, &span, t, common)?;
            ConnectionKind::JointCoordinate {
                joint: keys.joint,
                port: keys.port,
            }
        }
        rigid if RIGID_JOINT_TYPES.contains(&rigid) => {
            let spec: RigidJointSpec = params(src, &span, t, common)?;
            match rigid {
                "spherical" => ConnectionKind::Spherical(spec),
                "revolute" => ConnectionKind::Revolute(spec),
                "universal" => ConnectionKind::Universal(spec),
                "cylindrical" => ConnectionKind::Cylindrical(spec),
                "prismatic" => ConnectionKind::Prismatic(spec),
                "planar" => ConnectionKind::Planar(spec),
                _ => ConnectionKind::Fixed(spec),
            }
        }
        other => {
            let mut expected = vec!["node", "joint", "coupling", "joint_coordinate"];
            expected.extend(RIGID_JOINT_TYPES);
            return Err(SceneError::UnknownKind {
                at: Some(src.location(&type_span)),
                what: "connection type",
                name: other.to_string(),
                expected: listed(expected),
            });
        }
    };
    Ok(Connection { name, kind, origin })
}

fn parse_element(src: &Source<'_>, value: Spanned<DeValue<'_>>) -> Result<ElementSpec, SceneError> {
    let span = value.span();
    let DeValue::Table(mut t) = value.into_inner() else {
        return Err(src.error(
            &span,
            "`element` must be a table such as `{ type = \"spring\", k = 1.0 }`",
        ));
    };
    let (type_name, type_span) = take_string(src, &mut t, "type", "a coupling element", &span)?;
    let common = "`type`";
    Ok(match type_name.as_str() {
        "spring" => ElementSpec::Spring(params(src, &span, t, common)?),
        "damper" => ElementSpec::Damper(params(src, &span, t, common)?),
        "force_source" => ElementSpec::ForceSource(params(src, &span, t, common)?),
        other => {
            return Err(SceneError::UnknownKind {
                at: Some(src.location(&type_span)),
                what: "coupling element",
                name: other.to_string(),
                expected: listed(ELEMENT_TYPES),
            });
        }
    })
}
