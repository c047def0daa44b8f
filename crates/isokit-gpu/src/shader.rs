//! WGSL sources: assembling them from pieces with constants generated from Rust (so Rust is
//! the single source of truth for workgroup sizes and struct layouts), and validating them
//! with naga, the same front end wgpu uses, in unit tests.

/// A WGSL program assembled from `const` declarations and source pieces, in order.
///
/// ```
/// use isokit_gpu::ShaderSource;
/// let src = ShaderSource::new("demo")
///     .constant_u32("WORKGROUP", 64)
///     .constant_f32("EPS", 1e-6)
///     .piece("@compute @workgroup_size(WORKGROUP) fn main() { let e = EPS; }");
/// assert!(src.text().starts_with("const WORKGROUP: u32 = 64u;"));
/// src.validate().unwrap();
/// ```
#[derive(Clone, Debug)]
pub struct ShaderSource {
    label: String,
    text: String,
}

impl ShaderSource {
    /// An empty program named `label` (the name errors and debuggers show).
    pub fn new(label: &str) -> Self {
        Self {
            label: label.to_string(),
            text: String::new(),
        }
    }

    /// Appends `const NAME: u32 = value;`.
    pub fn constant_u32(mut self, name: &str, value: u32) -> Self {
        self.text
            .push_str(&format!("const {name}: u32 = {value}u;\n"));
        self
    }

    /// Appends `const NAME: f32 = value;` (printed so that it parses back to the same f32).
    pub fn constant_f32(mut self, name: &str, value: f32) -> Self {
        self.text
            .push_str(&format!("const {name}: f32 = {};\n", wgsl_f32(value)));
        self
    }

    /// Appends a piece of WGSL (typically a file of `shaders/`, one of the `isokit-shaders`
    /// crate's constants).
    pub fn piece(mut self, wgsl: &str) -> Self {
        self.text.push_str(wgsl);
        if !wgsl.ends_with('\n') {
            self.text.push('\n');
        }
        self
    }

    /// The program's label.
    pub fn label(&self) -> &str {
        &self.label
    }

    /// The assembled WGSL.
    pub fn text(&self) -> &str {
        &self.text
    }

    /// Parses and validates the program with naga (see [`validate_wgsl`]).
    pub fn validate(&self) -> Result<naga::valid::ModuleInfo, crate::GpuError> {
        validate_wgsl(&self.label, &self.text)
    }
}

/// An f32 as a WGSL literal that parses back to the same value (`1.0`, `1e-6`, `-3.5`).
fn wgsl_f32(v: f32) -> String {
    // Rust's `{:?}` prints the shortest round-trip form; WGSL accepts it when it has a
    // fraction or exponent.
    let s = format!("{v:?}");
    if s.contains(['.', 'e', 'E']) {
        s
    } else {
        format!("{s}.0")
    }
}

/// Parses `source` as WGSL and validates it with every check naga has (the capabilities of
/// a plain WebGPU device, which is what isokit requests). Returns naga's module info, or a
/// [`crate::GpuError::Shader`] carrying the diagnostic with the source line.
pub fn validate_wgsl(
    label: &str,
    source: &str,
) -> Result<naga::valid::ModuleInfo, crate::GpuError> {
    let module = naga::front::wgsl::parse_str(source).map_err(|e| crate::GpuError::Shader {
        label: label.to_string(),
        message: e.emit_to_string(source),
    })?;
    naga::valid::Validator::new(
        naga::valid::ValidationFlags::all(),
        naga::valid::Capabilities::default(),
    )
    .validate(&module)
    .map_err(|e| crate::GpuError::Shader {
        label: label.to_string(),
        message: e.emit_to_string(source),
    })
}

/// The size in bytes of the WGSL struct `name` in `source` as naga lays it out (storage
/// buffer rules), to check it against `size_of` of its `#[repr(C)]` Rust twin. `None` when the
/// source does not parse or has no such struct. Equal sizes do not make equal layouts: see
/// [`crate::check_wgsl_layout`] for the member-by-member check.
pub fn wgsl_struct_size(source: &str, name: &str) -> Option<u32> {
    let module = naga::front::wgsl::parse_str(source).ok()?;
    let mut layouter = naga::proc::Layouter::default();
    layouter.update(module.to_ctx()).ok()?;
    module
        .types
        .iter()
        .find(|(_, ty)| ty.name.as_deref() == Some(name))
        .map(|(h, _)| layouter[h].size)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn invalid_wgsl_is_reported_with_its_label() {
        let err = validate_wgsl("bad", "fn f() -> u32 { return 1.5; }").unwrap_err();
        let crate::GpuError::Shader { label, message } = err else {
            panic!("wrong error");
        };
        assert_eq!(label, "bad");
        assert!(!message.is_empty());
        // A parse error, too.
        assert!(validate_wgsl("parse", "fn (").is_err());
    }

    #[test]
    fn struct_sizes_come_from_naga() {
        let src = "struct A { x: vec3<f32>, y: f32, z: array<vec4<f32>, 2> }";
        assert_eq!(wgsl_struct_size(src, "A"), Some(48));
        assert_eq!(wgsl_struct_size(src, "B"), None);
    }

    #[test]
    fn f32_constants_round_trip() {
        for v in [1.0f32, 1e-6, -3.5, 0.1, f32::MAX, 1e30] {
            let src = ShaderSource::new("c").constant_f32("X", v);
            assert!(src.validate().is_ok(), "{}", src.text());
            let lit = src
                .text()
                .split('=')
                .nth(1)
                .unwrap()
                .trim()
                .trim_end_matches(';');
            assert_eq!(lit.parse::<f32>().unwrap(), v);
        }
    }
}
