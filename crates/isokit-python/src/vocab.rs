//! The modeling vocabulary from Python: 2D profiles, `extrude` and `revolve`, `mirror`,
//! `orient`, `affine`, non-uniform `transform` scales, repetition, deformations, `round` and
//! `onion`, chamfer and stairs blends, named parameters (`isokit.param`) and colours.
//!
//! Every such node is built by reading its scene-file form `{kind: {key: value, …}}` with the
//! scene crate's parser, so a script and a scene file describe the same tree, take the same
//! defaults and meet the same checks (the node is compiled once with stand-ins for its
//! children when it is made: a bad parameter, or a 2D profile where a solid is needed, is a
//! `ValueError` at once rather than at the first evaluation).
//!
//! A parameter (`isokit.param("r", 0.3)`) is a number that `to_json` writes as `"$r"`, with
//! the scene's `params` table: a shape remembers where its references are as JSON pointers
//! below its root ([`Shape::refs`](crate::shape::Shape)), moved below each parent that takes
//! it as a child.

use crate::errors::scene_err;
use crate::shape::Shape;
use crate::tree;
use isokit_scene::{Node, Scene, SceneFormat};
use pyo3::exceptions::{PyTypeError, PyValueError};
use pyo3::prelude::*;
use pyo3::types::{PyBool, PyDict, PyList, PyString, PyTuple};
use serde_json::{Map, Value, json};
use std::collections::BTreeMap;

/// A named number, `isokit.param(name, value)`: use it wherever a number of a shape is
/// expected (a radius, a count, a vector's component); `to_json()` writes it as `"$name"`
/// with a `params` table `{name: value}`, as scene files reference parameters. The value is
/// used when the shape is evaluated.
#[pyclass(frozen, module = "isokit", name = "Param")]
#[derive(Clone, Debug)]
pub struct Param {
    /// The name (a letter or `_` followed by letters, digits or `_`).
    #[pyo3(get)]
    pub name: String,
    /// The value (finite).
    #[pyo3(get)]
    pub value: f64,
}

#[pymethods]
impl Param {
    #[new]
    fn py_new(name: String, value: &Bound<'_, PyAny>) -> PyResult<Self> {
        if value.is_instance_of::<PyBool>() || value.extract::<f64>().is_err() {
            return Err(PyTypeError::new_err(format!(
                "param {name:?}: the value must be a number, got {}",
                value.get_type()
            )));
        }
        let x: f64 = value.extract()?;
        if !x.is_finite() {
            return Err(PyValueError::new_err(format!(
                "param {name:?}: the value {x} must be finite"
            )));
        }
        // The scene files' own rules for a parameter's name.
        let text = json!({"params": {&name: x}, "shape": {"sphere": {}}}).to_string();
        isokit_scene::parse(&text, SceneFormat::Json, "isokit.param").map_err(scene_err)?;
        Ok(Self { name, value: x })
    }

    fn __repr__(&self) -> String {
        format!("isokit.param({:?}, {})", self.name, self.value)
    }
}

/// Whether `value` is an `isokit.param` or a list or tuple holding one.
pub fn holds_param(value: &Bound<'_, PyAny>) -> bool {
    fn within(value: &Bound<'_, PyAny>, depth: usize) -> bool {
        value.is_instance_of::<Param>()
            || (depth < MAX_ARG_DEPTH
                && (value.is_instance_of::<PyList>() || value.is_instance_of::<PyTuple>())
                && value
                    .try_iter()
                    .map(|it| it.flatten().any(|v| within(&v, depth + 1)))
                    .unwrap_or(false))
    }
    within(value, 0)
}

/// `2` for a 2D profile (and operations on profiles), `3` for a solid. Includes count as
/// solids.
pub fn dim(node: &Node) -> u8 {
    // Down the first children (a loop: trees may be deep).
    let mut n = node;
    loop {
        match n {
            Node::Colored(c) => n = &c.of,
            n if n.profile().is_some() => return 2,
            Node::Extrude(_) | Node::Revolve(_) => return 3,
            _ => match n.children().first() {
                Some(c) => n = c,
                None => return 3,
            },
        }
    }
}

fn stand_in(dim: u8) -> Node {
    if dim == 2 {
        Node::circle(1.0, [0.0; 2])
    } else {
        Node::sphere(1.0, [0.0; 3])
    }
}

/// Compiles `node` with stand-ins (a unit circle or sphere of each child's dimension) for
/// its children: its own parameters and its children's dimensions are checked as a scene
/// file's would be, without building the children (a mesh is not read here).
pub fn check(node: &Node) -> PyResult<()> {
    let dims: Vec<u8> = node.children().into_iter().map(dim).collect();
    let mut probe = node.clone();
    for ((_, c), d) in tree::children_mut(&mut probe).into_iter().zip(dims) {
        *c = stand_in(d);
    }
    compiles(probe, node.kind())
}

/// Compiles `node` (stand-ins in place of costly children), errors named `isokit.KIND`.
fn compiles(node: Node, kind: &str) -> PyResult<()> {
    Scene::from_node(node).map(|_| ()).map_err(|mut e| {
        e.file = format!("isokit.{kind}");
        scene_err(e)
    })
}

/// Adds `from` to the parameter table `into`; one name with two values is an error.
pub fn merge_params(
    into: &mut BTreeMap<String, f64>,
    from: &BTreeMap<String, f64>,
) -> PyResult<()> {
    for (name, &x) in from {
        match into.get(name) {
            Some(&y) if y != x => {
                return Err(PyValueError::new_err(format!(
                    "the parameter {name:?} is {y} in one operand and {x} in another; give \
                     different values different names"
                )));
            }
            _ => {
                into.insert(name.clone(), x);
            }
        }
    }
    Ok(())
}

/// Writes `"$name"` at the JSON pointer `at` of a scene document. A key the document left
/// out (a value equal to its default, such as `"offset": 0`) is put back.
pub fn write_reference(doc: &mut Value, at: &str, name: &str) -> PyResult<()> {
    let reference = Value::String(format!("${name}"));
    if let Some(slot) = doc.pointer_mut(at) {
        *slot = reference;
        return Ok(());
    }
    let lost = || {
        pyo3::exceptions::PyRuntimeError::new_err(format!(
            "isokit: the parameter {name:?} lost its place {at} (a bug)"
        ))
    };
    let (parent, key) = at.rsplit_once('/').ok_or_else(lost)?;
    match doc.pointer_mut(parent) {
        Some(Value::Object(m)) => {
            m.insert(key.to_owned(), reference);
            Ok(())
        }
        None => {
            // A component of a vector left out: the only vectors scene files leave out at
            // their default are the axes (`[0, 0, 1]`). `to_json` checks the result reads
            // back as the shape.
            let (grand, vector) = parent.rsplit_once('/').ok_or_else(lost)?;
            let i: usize = key.parse().map_err(|_| lost())?;
            match doc.pointer_mut(grand) {
                Some(Value::Object(m)) if vector == "axis" && i < 3 => {
                    let mut axis = vec![json!(0.0), json!(0.0), json!(1.0)];
                    axis[i] = reference;
                    m.insert(vector.to_owned(), Value::Array(axis));
                    Ok(())
                }
                _ => Err(lost()),
            }
        }
        _ => Err(lost()),
    }
}

/// The references of a scene document's shape (`"$name"` strings below `/shape`), as
/// `(JSON pointer below the shape, name)`.
pub fn references(doc: &Value) -> Vec<(String, String)> {
    fn walk(v: &Value, at: String, out: &mut Vec<(String, String)>) {
        match v {
            Value::String(s) => {
                if let Some(name) = s.strip_prefix('$') {
                    out.push((at, name.to_owned()));
                }
            }
            Value::Array(a) => {
                for (i, x) in a.iter().enumerate() {
                    walk(x, format!("{at}/{i}"), out);
                }
            }
            Value::Object(o) => {
                for (k, x) in o {
                    walk(x, format!("{at}/{k}"), out);
                }
            }
            _ => {}
        }
    }
    let mut out = Vec::new();
    if let Some(shape) = doc.get("shape") {
        walk(shape, String::new(), &mut out);
    }
    out
}

/// How deeply an argument's lists may nest (a matrix nests 2, polygon points 2).
const MAX_ARG_DEPTH: usize = 8;

/// Python `value` (numbers, params, sequences of them, dicts of them) as the JSON a scene
/// file holds, with each parameter written as `"$name"`, its JSON pointer (`ptr`) recorded
/// in `refs` and its value in `params`. `name` names the argument in errors.
fn to_json(
    value: &Bound<'_, PyAny>,
    name: &str,
    ptr: &str,
    refs: &mut Vec<(String, String)>,
    params: &mut BTreeMap<String, f64>,
) -> PyResult<Value> {
    if ptr.matches('/').count() > MAX_ARG_DEPTH + 2 {
        return Err(PyValueError::new_err(format!(
            "{name}: nested more than {MAX_ARG_DEPTH} levels deep"
        )));
    }
    if let Ok(p) = value.cast::<Param>() {
        let p = p.get();
        merge_params(params, &BTreeMap::from([(p.name.clone(), p.value)]))?;
        refs.push((ptr.to_owned(), p.name.clone()));
        return Ok(Value::String(format!("${}", p.name)));
    }
    let bad = || {
        PyTypeError::new_err(format!(
            "{name} must be a number, an isokit.param or a sequence of them, got {}",
            value.get_type()
        ))
    };
    if value.is_instance_of::<PyBool>()
        || value.is_instance_of::<PyString>()
        || value.is_instance_of::<Shape>()
    {
        return Err(bad());
    }
    if let Ok(d) = value.cast::<PyDict>() {
        let mut m = Map::new();
        for (k, v) in d.iter() {
            let k: String = k.extract()?;
            if !v.is_none() {
                let j = to_json(
                    &v,
                    &format!("{name}.{k}"),
                    &format!("{ptr}/{k}"),
                    refs,
                    params,
                )?;
                m.insert(k, j);
            }
        }
        return Ok(Value::Object(m));
    }
    if value.is_instance_of::<PyList>() || value.is_instance_of::<PyTuple>() {
        let mut out = Vec::new();
        for (i, v) in value.try_iter()?.enumerate() {
            out.push(to_json(
                &v?,
                &format!("{name}[{i}]"),
                &format!("{ptr}/{i}"),
                refs,
                params,
            )?);
        }
        return Ok(Value::Array(out));
    }
    if let Ok(i) = value.extract::<i64>() {
        return Ok(Value::from(i));
    }
    if let Ok(x) = value.extract::<f64>() {
        return serde_json::Number::from_f64(x)
            .map(Value::Number)
            .ok_or_else(|| PyValueError::new_err(format!("{name} = {x} must be finite")));
    }
    if value.hasattr("tolist")? {
        // A NumPy array (polygon points, a matrix).
        return to_json(&value.call_method0("tolist")?, name, ptr, refs, params);
    }
    Err(bad())
}

/// The children of a built node: none, one (`"of": child`) or a list (`"of": [a, b, …]`).
pub enum Of<'a> {
    /// A source (a profile, a primitive with parameters).
    Nothing,
    /// One child.
    One(&'a Shape),
    /// A list of operands.
    Many(Vec<&'a Shape>),
}

impl Of<'_> {
    fn shapes(&self) -> Vec<&Shape> {
        match self {
            Of::Nothing => Vec::new(),
            Of::One(s) => vec![*s],
            Of::Many(v) => v.clone(),
        }
    }
}

/// Builds the node `{kind: {key: value, …, "of": children}}` (arguments that are `None`
/// are left out and take the scene files' defaults), checks it (see [`check`]) and gives it
/// `color` when one is given.
pub fn build(
    kind: &str,
    args: &[(&str, Option<&Bound<'_, PyAny>>)],
    of: Of<'_>,
    color: Option<&Bound<'_, PyAny>>,
) -> PyResult<Shape> {
    let mut refs = Vec::new();
    let mut params = BTreeMap::new();
    let mut body = Map::new();
    for (key, value) in args {
        if let Some(v) = value.filter(|v| !v.is_none()) {
            let j = to_json(v, key, &format!("/{kind}/{key}"), &mut refs, &mut params)?;
            body.insert((*key).to_owned(), j);
        }
    }
    let kids = of.shapes();
    let placeholder = |s: &Shape| {
        if dim(s.node()) == 2 {
            json!({"circle": {}})
        } else {
            json!({"sphere": {}})
        }
    };
    match &of {
        Of::Nothing => {}
        Of::One(s) => {
            body.insert("of".to_owned(), placeholder(s));
        }
        Of::Many(v) => {
            body.insert(
                "of".to_owned(),
                Value::Array(v.iter().map(|s| placeholder(s)).collect()),
            );
        }
    }
    let text = json!({"params": params, "shape": {kind: body}}).to_string();
    let file = isokit_scene::parse(&text, SceneFormat::Json, &format!("isokit.{kind}"))
        .map_err(scene_err)?;
    let mut node = file.shape;
    if let Some(c) = color.filter(|c| !c.is_none()) {
        node = node.with_color(crate::shape::vec3_arg(c, "color")?);
    }
    compiles(node.clone(), kind)?;
    let slots = tree::children_mut(&mut node);
    if slots.len() != kids.len() {
        return Err(PyValueError::new_err(format!(
            "{kind} takes {} shapes, got {}",
            slots.len(),
            kids.len()
        )));
    }
    for ((slot, c), kid) in slots.into_iter().zip(&kids) {
        *c = kid.node().clone();
        merge_params(&mut params, &kid.file.params)?;
        let base = slot.pointer(kind);
        refs.extend(
            kid.refs
                .iter()
                .map(|(p, n)| (format!("{base}{p}"), n.clone())),
        );
    }
    Ok(Shape::from_parts(node, params, refs))
}

/// `isokit._node(kind, args, of, color)`: the node of `kind` from a dict of its scene-file
/// keys, with `of` a shape, a list of shapes or `None` (see [`build`]).
#[pyfunction]
#[pyo3(signature = (kind, args, of = None, color = None))]
pub fn _node(
    kind: &str,
    args: &Bound<'_, PyDict>,
    of: Option<&Bound<'_, PyAny>>,
    color: Option<&Bound<'_, PyAny>>,
) -> PyResult<Shape> {
    let pairs: Vec<(String, Bound<'_, PyAny>)> = args
        .iter()
        .map(|(k, v)| Ok((k.extract::<String>()?, v)))
        .collect::<PyResult<_>>()?;
    let args: Vec<(&str, Option<&Bound<'_, PyAny>>)> =
        pairs.iter().map(|(k, v)| (k.as_str(), Some(v))).collect();
    let not_shape = |x: &Bound<'_, PyAny>| {
        PyTypeError::new_err(format!("{kind} takes shapes, got {}", x.get_type()))
    };
    match of {
        None => build(kind, &args, Of::Nothing, color),
        Some(o) if o.is_none() => build(kind, &args, Of::Nothing, color),
        Some(o) => {
            if let Ok(s) = o.cast::<Shape>() {
                return build(kind, &args, Of::One(s.get()), color);
            }
            let items: Vec<Bound<'_, PyAny>> = o.try_iter()?.collect::<PyResult<_>>()?;
            let shapes: Vec<Bound<'_, Shape>> = items
                .iter()
                .map(|x| x.cast::<Shape>().cloned().map_err(|_| not_shape(x)))
                .collect::<PyResult<_>>()?;
            if shapes.is_empty() {
                return Err(PyValueError::new_err(format!(
                    "{kind} needs at least one shape"
                )));
            }
            build(
                kind,
                &args,
                Of::Many(shapes.iter().map(|s| s.get()).collect()),
                color,
            )
        }
    }
}

/// `isokit._profiles()`: the 2D profiles with defaults, `[(key, {name: default}), …]` (the
/// polygon has none: it needs its points), vectors as tuples.
#[pyfunction]
pub fn _profiles(py: Python<'_>) -> PyResult<Bound<'_, PyList>> {
    use isokit_scene::profiles::{
        CircleNode, EllipseNode, HexagonNode, RectangleNode, RoundedRectangleNode, SlotNode,
    };
    let defaults = [
        ("circle", serde_json::to_value(CircleNode::default())),
        ("rectangle", serde_json::to_value(RectangleNode::default())),
        (
            "rounded_rectangle",
            serde_json::to_value(RoundedRectangleNode::default()),
        ),
        ("ellipse", serde_json::to_value(EllipseNode::default())),
        ("slot", serde_json::to_value(SlotNode::default())),
        ("hexagon", serde_json::to_value(HexagonNode::default())),
    ];
    // The shortest decimal of each float32 (0.1, not 0.10000000149011612).
    let short = |x: &Value| {
        let x = x.as_f64().unwrap_or(f64::NAN) as f32;
        x.to_string().parse::<f64>().unwrap_or(f64::from(x))
    };
    let out = PyList::empty(py);
    for (key, v) in defaults {
        let v = v.map_err(crate::errors::value_err)?;
        let d = PyDict::new(py);
        for (name, x) in v.as_object().into_iter().flatten() {
            let x: Bound<'_, PyAny> = match x {
                Value::Array(a) => PyTuple::new(py, a.iter().map(short))?.into_any(),
                x => short(x).into_pyobject(py)?.into_any(),
            };
            d.set_item(name, x)?;
        }
        out.append((key, d))?;
    }
    Ok(out)
}
