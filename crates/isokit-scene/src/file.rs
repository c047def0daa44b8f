//! A whole scene file: the shape tree and the renderer's and sampler's settings, read from
//! JSON or TOML through one serde view ([`parse`]), written back as JSON
//! ([`SceneFile::to_json`]), described by a JSON Schema ([`json_schema`]).

use crate::SceneError;
use crate::node::Node;
use isokit_render::ShadingMode;
use schemars::JsonSchema;
use serde::{Deserialize, Serialize};
use std::collections::BTreeMap;
use std::path::Path;

/// The scene format version this library reads and writes.
pub const VERSION: u32 = 1;

fn zero3() -> [f32; 3] {
    [0.0; 3]
}

fn up() -> [f32; 3] {
    [0.0, 1.0, 0.0]
}

fn fov() -> f32 {
    45.0
}

fn one() -> f32 {
    1.0
}

fn white() -> [f32; 3] {
    [1.0; 3]
}

/// The camera of the renderer.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize, JsonSchema)]
#[serde(deny_unknown_fields)]
pub struct CameraSpec {
    /// Eye position.
    pub eye: [f32; 3],
    /// The point looked at (default the origin).
    #[serde(default = "zero3")]
    pub target: [f32; 3],
    /// Up direction (default +y).
    #[serde(default = "up")]
    pub up: [f32; 3],
    /// Vertical field of view in degrees (default 45).
    #[serde(default = "fov")]
    pub fov: f32,
    /// With orthographic projection: the view's height in world units (default: what the
    /// perspective view shows in the plane of the target, `2 · |target − eye| · tan(fov/2)`).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub ortho_height: Option<f32>,
}

/// A light: directional when `direction` is given, a point light at `position` otherwise.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize, JsonSchema)]
#[serde(deny_unknown_fields)]
pub struct LightSpec {
    /// Direction the light travels (for a directional light).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub direction: Option<[f32; 3]>,
    /// Position (for a point light).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub position: Option<[f32; 3]>,
    /// Linear RGB colour (default white).
    #[serde(default = "white")]
    pub color: [f32; 3],
    /// Intensity factor (default 1).
    #[serde(default = "one")]
    pub intensity: f32,
}

/// A shading mode of the renderer by name (`phong`, `curvature`, … : every name of
/// [`ShadingMode::ALL`]).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct ShadingName(pub ShadingMode);

impl Serialize for ShadingName {
    fn serialize<S: serde::Serializer>(&self, s: S) -> Result<S::Ok, S::Error> {
        s.serialize_str(self.0.name())
    }
}

impl<'de> Deserialize<'de> for ShadingName {
    fn deserialize<D: serde::Deserializer<'de>>(d: D) -> Result<Self, D::Error> {
        let s = String::deserialize(d)?;
        s.parse::<ShadingMode>()
            .map(ShadingName)
            .map_err(serde::de::Error::custom)
    }
}

impl JsonSchema for ShadingName {
    fn schema_name() -> std::borrow::Cow<'static, str> {
        "ShadingMode".into()
    }
    fn json_schema(_: &mut schemars::SchemaGenerator) -> schemars::Schema {
        let names: Vec<&str> = ShadingMode::ALL.iter().map(|(n, _)| *n).collect();
        schemars::json_schema!({
            "description": "A shading mode of the renderer.",
            "type": "string",
            "enum": names,
        })
    }
}

/// Surface shading of the renderer.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize, JsonSchema)]
#[serde(deny_unknown_fields)]
pub struct ShadingSpec {
    /// The shading mode (default `phong`).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub mode: Option<ShadingName>,
    /// Base colour, linear RGB (default light grey).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub color: Option<[f32; 3]>,
    /// Ambient term (default 0.1).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub ambient: Option<f32>,
    /// Specular exponent (default 32).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub shininess: Option<f32>,
}

/// How the scene is sampled to a grid.
#[derive(Clone, Debug, Default, PartialEq, Serialize, Deserialize, JsonSchema)]
#[serde(deny_unknown_fields)]
pub struct SamplingSpec {
    /// Samples along the longest side of the domain (default 128).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub resolution: Option<usize>,
    /// Narrow band half-width in world units (default 4 voxels).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub band: Option<f32>,
    /// Brick size, a power of two from 2 to 256 (default 4).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub brick: Option<usize>,
    /// The domain, `[[xmin, ymin, zmin], [xmax, ymax, zmax]]` (default: the shape's
    /// bounds, padded by the band and two voxels). Required for unbounded shapes.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub bounds: Option<[[f32; 3]; 2]>,
}

fn is_empty_sampling(s: &SamplingSpec) -> bool {
    *s == SamplingSpec::default()
}

/// A whole scene file: the shape tree and the renderer's settings.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize, JsonSchema)]
#[serde(deny_unknown_fields)]
pub struct SceneFile {
    /// The scene format's version (default and only version: 1).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub version: Option<u32>,
    /// Named numbers (`{"r": 0.3}`) that any number of the scene may reference as the string
    /// `"$r"` (numbers only: not vectors, nodes or names). [`parse`] substitutes them before
    /// reading the rest, so the tree holds their values; the table is kept for front ends
    /// that offer the parameters as sliders and re-read the scene with
    /// [`parse_with_params`].
    #[serde(default, skip_serializing_if = "BTreeMap::is_empty")]
    pub params: BTreeMap<String, f64>,
    /// The shape tree.
    pub shape: Node,
    /// Camera of the renderer.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub camera: Option<CameraSpec>,
    /// Lights of the renderer.
    #[serde(default, skip_serializing_if = "Vec::is_empty")]
    pub lights: Vec<LightSpec>,
    /// Shading of the renderer.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub shading: Option<ShadingSpec>,
    /// Grid sampling.
    #[serde(default, skip_serializing_if = "is_empty_sampling")]
    pub sampling: SamplingSpec,
}

impl SceneFile {
    /// A scene of just `shape`, with default camera, lights, shading and sampling.
    pub fn new(shape: Node) -> Self {
        Self {
            version: None,
            params: BTreeMap::new(),
            shape,
            camera: None,
            lights: Vec::new(),
            shading: None,
            sampling: SamplingSpec::default(),
        }
    }

    /// The scene as JSON text (pretty-printed), as a scene file holds it. Refuses, naming
    /// the node, a scene with sources held in memory: save them to files and reference the
    /// files instead.
    pub fn to_json(&self) -> Result<String, SceneError> {
        if let Some(node) = self.shape.first_in_memory("shape") {
            return Err(SceneError::new(
                "<scene>",
                &node,
                "holds data in memory, which a scene file cannot: save it to a file and \
                 reference it by `path`",
            ));
        }
        serde_json::to_string_pretty(self)
            .map_err(|e| SceneError::new("<scene>", "", format!("cannot write JSON: {e}")))
    }
}

/// Scene file syntax.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum SceneFormat {
    /// JSON (`.json`).
    Json,
    /// TOML (`.toml`).
    Toml,
}

impl SceneFormat {
    /// From a path's extension.
    pub fn from_path(path: &Path) -> Option<Self> {
        let ext = path.extension()?.to_str()?.to_ascii_lowercase();
        match ext.as_str() {
            "json" => Some(Self::Json),
            "toml" => Some(Self::Toml),
            _ => None,
        }
    }
}

/// Parses scene text into the typed scene (through one serde view for both syntaxes: TOML
/// is read into the same JSON value first). Errors name `file`, the node path
/// (`shape.union[1].sphere.radius`) and the problem.
///
/// Nesting deeper than [`MAX_NESTING`] brackets (or dotted TOML keys) is refused before
/// parsing; below it the parse has no recursion limit of its own (a 100-deep `transform`
/// chain nests 200 brackets) and runs on a thread with a stack sized for the cap.
pub fn parse(text: &str, format: SceneFormat, file: &str) -> Result<SceneFile, SceneError> {
    parse_with_params(text, format, file, &BTreeMap::new())
}

/// [`parse`] with some of the scene's `params` given other values (a slider moved):
/// `overrides` names parameters the scene declares (others are an error) and their values
/// (finite).
pub fn parse_with_params(
    text: &str,
    format: SceneFormat,
    file: &str,
    overrides: &BTreeMap<String, f64>,
) -> Result<SceneFile, SceneError> {
    let depth = nesting_depth(text, format);
    if depth > MAX_NESTING {
        return Err(SceneError::new(
            file,
            "",
            format!(
                "nesting deeper than {MAX_NESTING} levels (brackets or dotted keys) is not read; this file nests at least {depth}"
            ),
        ));
    }
    if depth <= 64 {
        return parse_nested(text, format, file, overrides);
    }
    std::thread::scope(|s| {
        std::thread::Builder::new()
            .name("scene parse".into())
            .stack_size(PARSE_STACK)
            .spawn_scoped(s, || parse_nested(text, format, file, overrides))
            .map_err(|e| SceneError::new(file, "", format!("cannot start the parser: {e}")))?
            .join()
            .unwrap_or_else(|_| Err(SceneError::new(file, "", "the parser failed")))
    })
}

/// The deepest nesting [`parse`] reads: brackets of JSON, brackets and dotted keys of TOML.
/// A node nests two levels (`{"transform": {"of": …}}`), so this allows chains of 500 nodes.
pub const MAX_NESTING: usize = 1000;

/// The parser thread's stack: room for [`MAX_NESTING`] levels of the derived deserializers in
/// unoptimized builds.
const PARSE_STACK: usize = 256 << 20;

/// An upper bound of the nesting depth of scene text, without parsing: the deepest run of
/// open brackets outside strings (JSON and TOML), plus for TOML the most dots in one line's
/// key (dotted keys nest tables).
pub fn nesting_depth(text: &str, format: SceneFormat) -> usize {
    let b = text.as_bytes();
    let (mut depth, mut max, mut i) = (0usize, 0usize, 0usize);
    // TOML: dots of the current line's key part (before its first `=` outside strings).
    let (mut key_dots, mut in_key) = (0usize, true);
    let toml = format == SceneFormat::Toml;
    while i < b.len() {
        match b[i] {
            b'"' | b'\'' if toml || b[i] == b'"' => {
                let q = b[i];
                let triple = toml && b[i..].starts_with(&[q, q, q]);
                i += if triple { 3 } else { 1 };
                while i < b.len() {
                    if q == b'"' && b[i] == b'\\' {
                        i += 2;
                        continue;
                    }
                    if triple {
                        if b[i..].starts_with(&[q, q, q]) {
                            i += 3;
                            break;
                        }
                    } else if b[i] == q || (toml && b[i] == b'\n') {
                        i += 1;
                        break;
                    }
                    i += 1;
                }
                continue;
            }
            b'#' if toml => {
                while i < b.len() && b[i] != b'\n' {
                    i += 1;
                }
                continue;
            }
            b'[' | b'{' => {
                depth += 1;
                max = max.max(depth + key_dots);
            }
            b']' | b'}' => depth = depth.saturating_sub(1),
            b'.' if toml && in_key => {
                key_dots += 1;
                max = max.max(depth + key_dots);
            }
            b'=' if toml => in_key = false,
            b'\n' if toml => {
                key_dots = 0;
                in_key = true;
            }
            b',' if toml && depth > 0 => in_key = true,
            _ => {}
        }
        i += 1;
    }
    max
}

fn parse_nested(
    text: &str,
    format: SceneFormat,
    file: &str,
    overrides: &BTreeMap<String, f64>,
) -> Result<SceneFile, SceneError> {
    let mut value: serde_json::Value = match format {
        SceneFormat::Json => {
            use serde::Deserialize;
            let mut de = serde_json::Deserializer::from_str(text);
            // Depth is bounded by `nesting_depth` above.
            de.disable_recursion_limit();
            serde_json::Value::deserialize(&mut de)
                .and_then(|v| de.end().map(|()| v))
                .map_err(|e| SceneError::new(file, "", format!("invalid JSON: {e}")))?
        }
        SceneFormat::Toml => {
            let table: toml::Value = toml::from_str(text).map_err(|e| {
                // The message and where, without the quoted source line (which may be long).
                let at = e.span().map_or(String::new(), |r| {
                    let before = &text[..r.start.min(text.len())];
                    let line = before.matches('\n').count() + 1;
                    let col = before.len() - before.rfind('\n').map_or(0, |i| i + 1) + 1;
                    format!(" at line {line} column {col}")
                });
                SceneError::new(
                    file,
                    "",
                    format!("invalid TOML{at}: {}", e.message().trim()),
                )
            })?;
            if let Some(node) = non_finite(&table, String::new()) {
                return Err(SceneError::new(
                    file,
                    &node,
                    "nan and inf are not allowed (numbers must be finite)",
                ));
            }
            serde_json::to_value(table)
                .map_err(|e| SceneError::new(file, "", format!("invalid TOML: {e}")))?
        }
    };
    if !value.is_object() {
        return Err(SceneError::new(
            file,
            "",
            "a scene is a table with the key `shape`",
        ));
    }
    crate::params::substitute(&mut value, overrides)
        .map_err(|(node, message)| SceneError::new(file, &node, message))?;
    let scene: SceneFile = serde_path_to_error::deserialize(value).map_err(|e| {
        let node = e.path().to_string();
        let node = if node == "." { String::new() } else { node };
        SceneError::new(file, &node, e.into_inner().to_string())
    })?;
    if let Some(v) = scene.version
        && v != VERSION
    {
        return Err(SceneError::new(
            file,
            "version",
            format!(
                "scene format version {v} is not supported (this isokit reads version {VERSION})"
            ),
        ));
    }
    Ok(scene)
}

/// The path (in `serde_path_to_error`'s notation) of the first non-finite float in `v`.
fn non_finite(v: &toml::Value, path: String) -> Option<String> {
    let join = |k: &str| {
        if path.is_empty() {
            k.to_owned()
        } else {
            format!("{path}.{k}")
        }
    };
    match v {
        toml::Value::Float(f) if !f.is_finite() => Some(path),
        toml::Value::Table(t) => t.iter().find_map(|(k, v)| non_finite(v, join(k))),
        toml::Value::Array(a) => a
            .iter()
            .enumerate()
            .find_map(|(i, v)| non_finite(v, format!("{path}[{i}]"))),
        _ => None,
    }
}

/// The JSON Schema of scene files (draft 2020-12), generated from the types: editors use
/// it to complete and check scenes. The repository ships it as `docs/scene.schema.json`
/// (a test keeps the two equal).
pub fn json_schema() -> serde_json::Value {
    let mut schema = schemars::schema_for!(SceneFile);
    schema.insert(
        "$id".to_owned(),
        "https://example.invalid/isokit/scene.schema.json".into(),
    );
    schema.insert("title".to_owned(), "isokit scene".into());
    let mut v = serde_json::to_value(schema).unwrap_or_default();
    crate::node::add_color_to_schema(&mut v);
    add_param_refs(&mut v);
    v
}

/// Lets every number of a generated schema be a parameter reference (`"$r"`, `$defs.Param`)
/// as [`parse`] allows, except in the `params` table itself; the wrapper keeps the number's
/// description and default.
fn add_param_refs(schema: &mut serde_json::Value) {
    use serde_json::{Value, json};
    fn is_number(v: &Value) -> bool {
        let num = |t: &Value| matches!(t.as_str(), Some("number" | "integer"));
        match v.get("type") {
            Some(Value::Array(ts)) => ts.iter().any(num),
            Some(t) => num(t),
            None => false,
        }
    }
    fn walk(v: &mut Value) {
        let number = is_number(v);
        match v {
            Value::Object(o) => {
                if number {
                    let mut wrapper = serde_json::Map::new();
                    for key in ["description", "default"] {
                        if let Some(x) = o.remove(key) {
                            wrapper.insert(key.to_owned(), x);
                        }
                    }
                    let number = Value::Object(std::mem::take(o));
                    wrapper.insert(
                        "anyOf".to_owned(),
                        json!([number, {"$ref": "#/$defs/Param"}]),
                    );
                    *o = wrapper;
                    return;
                }
                for x in o.values_mut() {
                    walk(x);
                }
            }
            Value::Array(a) => a.iter_mut().for_each(walk),
            _ => {}
        }
    }
    let Some(root) = schema.as_object_mut() else {
        return;
    };
    let params = root
        .get_mut("properties")
        .and_then(|p| p.as_object_mut())
        .and_then(|p| p.remove("params"));
    let mut whole = Value::Object(std::mem::take(root));
    walk(&mut whole);
    if let Value::Object(o) = whole {
        *root = o;
    }
    if let (Some(p), Some(props)) = (
        params,
        root.get_mut("properties").and_then(|p| p.as_object_mut()),
    ) {
        props.insert("params".to_owned(), p);
    }
    if let Some(defs) = root.get_mut("$defs").and_then(|d| d.as_object_mut()) {
        defs.insert(
            "Param".to_owned(),
            json!({
                "description": "A reference to a number of the scene's `params` table, \
                    e.g. \"$r\" for {\"params\": {\"r\": 0.3}}: allowed wherever a number is.",
                "type": "string",
                "pattern": "^\\$[A-Za-z_][A-Za-z0-9_]*$",
            }),
        );
    }
}
