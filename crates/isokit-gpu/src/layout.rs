//! WGSL structs checked against their `#[repr(C)]` Rust twins member by member: name, byte
//! offset and type, read from naga's reflection of the WGSL and from `offset_of!` and the
//! field types on the Rust side.
//!
//! [`crate::wgsl_struct_size`] alone lets two fields of equal size trade places (or a `u32`
//! become an `f32`) unnoticed; [`check_wgsl_layout`] does not. The Rust side of a shared struct
//! declares its table next to the type with [`wgsl_layout!`](crate::wgsl_layout), which
//! builds it from the struct's own fields (so the offsets and sizes are the compiler's), and a
//! unit test compares it with every assembled shader that declares the struct:
//!
//! ```
//! use isokit_gpu::check_wgsl_layout;
//!
//! #[repr(C)]
//! #[derive(Clone, Copy, bytemuck::Pod, bytemuck::Zeroable)]
//! struct Light {
//!     dir: [f32; 3],
//!     point: u32,
//!     color: [f32; 3],
//!     intensity: f32,
//! }
//! isokit_gpu::wgsl_layout!(Light {
//!     dir: "vec3<f32>",
//!     point: "u32",
//!     color: "vec3<f32>",
//!     intensity: "f32",
//! });
//!
//! let ok = "struct Light { dir: vec3<f32>, point: u32, color: vec3<f32>, intensity: f32 }";
//! assert!(check_wgsl_layout::<Light>(ok).is_ok());
//! // Two 4-byte members swapped: the sizes still agree, the layout does not.
//! let swapped = "struct Light { dir: vec3<f32>, intensity: f32, color: vec3<f32>, point: u32 }";
//! assert!(check_wgsl_layout::<Light>(swapped).is_err());
//! ```

use naga::common::wgsl::TypeContext;

/// One member of a WGSL struct as naga lays it out (storage-buffer rules).
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct WgslMember {
    /// The member's name.
    pub name: String,
    /// Byte offset from the start of the struct.
    pub offset: u32,
    /// Size in bytes of the member's type.
    pub size: u32,
    /// The member's type as WGSL spells it: `f32`, `vec3<f32>`, `mat4x4<f32>`,
    /// `array<vec4<f32>, 5>`, `atomic<u32>`, or a struct's name.
    pub ty: String,
}

/// The WGSL struct `name` in `source`: its size and its members in declaration order.
fn reflect(source: &str, name: &str) -> Option<(u32, Vec<WgslMember>)> {
    let module = naga::front::wgsl::parse_str(source).ok()?;
    let mut layouter = naga::proc::Layouter::default();
    layouter.update(module.to_ctx()).ok()?;
    let (handle, ty) = module
        .types
        .iter()
        .find(|(_, ty)| ty.name.as_deref() == Some(name))?;
    let naga::TypeInner::Struct { members, .. } = &ty.inner else {
        return None;
    };
    let ctx = module.to_ctx();
    let members = members
        .iter()
        .map(|m| WgslMember {
            name: m.name.clone().unwrap_or_default(),
            offset: m.offset,
            size: layouter[m.ty].size,
            ty: ctx.type_to_string(m.ty),
        })
        .collect();
    Some((layouter[handle].size, members))
}

/// The members of the WGSL struct `name` in `source` (name, offset, size and type of each, in
/// declaration order), as naga lays them out. `None` when the source does not parse or has
/// no struct of that name.
///
/// ```
/// let src = "struct A { x: vec3<f32>, y: f32, z: array<vec4<f32>, 2> }";
/// let a = isokit_gpu::wgsl_struct_layout(src, "A").unwrap();
/// let row: Vec<(&str, u32, &str)> =
///     a.iter().map(|m| (m.name.as_str(), m.offset, m.ty.as_str())).collect();
/// assert_eq!(row, [("x", 0, "vec3<f32>"), ("y", 12, "f32"), ("z", 16, "array<vec4<f32>, 2>")]);
/// ```
pub fn wgsl_struct_layout(source: &str, name: &str) -> Option<Vec<WgslMember>> {
    reflect(source, name).map(|(_, members)| members)
}

/// A Rust type that stands for a WGSL type in a struct shared with the GPU: which WGSL
/// spellings (naga's, as in [`WgslMember::ty`]) have its bytes and meaning. Implemented for
/// `f32`, `u32`, `i32`, arrays of these (WGSL vectors, matrices and arrays) and, by
/// [`wgsl_layout!`](crate::wgsl_layout), for every struct with a table.
pub trait WgslType {
    /// True when a WGSL member of type `wgsl` can be this Rust type.
    fn matches_wgsl(wgsl: &str) -> bool;
}

impl WgslType for f32 {
    fn matches_wgsl(wgsl: &str) -> bool {
        wgsl == "f32"
    }
}

impl WgslType for u32 {
    fn matches_wgsl(wgsl: &str) -> bool {
        matches!(wgsl, "u32" | "atomic<u32>")
    }
}

impl WgslType for i32 {
    fn matches_wgsl(wgsl: &str) -> bool {
        matches!(wgsl, "i32" | "atomic<i32>")
    }
}

/// `[T; N]` is `array<X, N>` for every `X` that `T` is; `vecN<S>` for a scalar `S` that `T`
/// is; and `matNxR<S>` (N columns of `vecR<S>`) when `T` is `vecR<S>`.
impl<T: WgslType, const N: usize> WgslType for [T; N] {
    fn matches_wgsl(wgsl: &str) -> bool {
        let scalar = |s: &str| matches!(s, "f32" | "u32" | "i32") && T::matches_wgsl(s);
        if let Some(inner) = wgsl
            .strip_prefix("array<")
            .and_then(|r| r.strip_suffix('>'))
        {
            return inner
                .rsplit_once(", ")
                .is_some_and(|(elem, n)| n.parse() == Ok(N) && T::matches_wgsl(elem));
        }
        if let Some(rest) = wgsl.strip_prefix("vec").and_then(|r| r.strip_suffix('>')) {
            return rest
                .split_once('<')
                .is_some_and(|(n, s)| n.parse() == Ok(N) && scalar(s));
        }
        if let Some(rest) = wgsl.strip_prefix("mat").and_then(|r| r.strip_suffix('>')) {
            return rest.split_once('<').is_some_and(|(dims, s)| {
                dims.split_once('x').is_some_and(|(c, r)| {
                    c.parse() == Ok(N) && T::matches_wgsl(&format!("vec{r}<{s}>"))
                })
            });
        }
        false
    }
}

/// One field of a `#[repr(C)]` Rust struct shared with WGSL, and the WGSL member it is:
/// one row of a [`WgslStruct`]'s table, built by [`wgsl_layout!`](crate::wgsl_layout).
#[derive(Clone, Copy, Debug)]
pub struct GpuField {
    /// The WGSL member's name (the Rust field's, unless renamed in the table).
    pub name: &'static str,
    /// The Rust field's name.
    pub rust_name: &'static str,
    /// The Rust field's byte offset (`offset_of!`).
    pub offset: usize,
    /// The Rust field's size in bytes.
    pub size: usize,
    /// The WGSL member's type as naga spells it (see [`WgslMember::ty`]).
    pub wgsl_type: &'static str,
    /// [`WgslType::matches_wgsl`] of the Rust field's type.
    pub rust_matches: fn(&str) -> bool,
    /// The Rust field's type name, for messages.
    pub rust_type: fn() -> &'static str,
}

/// A `#[repr(C)]` Rust struct with a WGSL twin: its WGSL name and its fields, each with the
/// WGSL member it is. Implemented by [`wgsl_layout!`](crate::wgsl_layout); checked by
/// [`check_wgsl_layout`].
pub trait WgslStruct: Sized {
    /// The WGSL struct's name.
    const WGSL_NAME: &'static str;
    /// Every field, in the order of the WGSL members.
    const FIELDS: &'static [GpuField];
}

/// The size of the field that `probe` reaches (the macro's way to `size_of` a field's type
/// without naming it).
pub const fn field_size<T, F>(_probe: fn(&T) -> &F) -> usize {
    size_of::<F>()
}

/// [`WgslType::matches_wgsl`] of the type of the field that `probe` reaches.
pub const fn field_matcher<T, F: WgslType>(_probe: fn(&T) -> &F) -> fn(&str) -> bool {
    F::matches_wgsl
}

/// The type name of the field that `probe` reaches.
pub const fn field_type_name<T, F>(_probe: fn(&T) -> &F) -> fn() -> &'static str {
    core::any::type_name::<F>
}

/// Declares the WGSL twin of a `#[repr(C)]` struct, field by field, next to the Rust type:
/// implements [`WgslStruct`] (the table: each field's WGSL member name and type, with the
/// field's `offset_of!`, size and type taken from the struct itself) and [`WgslType`] (so the
/// struct can be a member of another shared struct).
///
/// Every field of the struct must be listed, in the order of the WGSL members. A field whose
/// WGSL member has another name (a WGSL reserved word) is written `field as "member"`; a
/// struct whose WGSL name differs, `Type as "Name"`.
///
/// ```
/// #[repr(C)]
/// #[derive(Clone, Copy, bytemuck::Pod, bytemuck::Zeroable)]
/// struct Pixel {
///     normal: [f32; 3],
///     filter: u32,
/// }
/// isokit_gpu::wgsl_layout!(Pixel as "GPixel" {
///     normal: "vec3<f32>",
///     filter as "search_filter": "u32",
/// });
///
/// let src = "struct GPixel { normal: vec3<f32>, search_filter: u32 }";
/// isokit_gpu::check_wgsl_layout::<Pixel>(src).unwrap();
/// ```
#[macro_export]
macro_rules! wgsl_layout {
    ($rust:ty $(as $wgsl:literal)? {
        $($field:ident $(as $member:literal)? : $ty:literal),* $(,)?
    }) => {
        impl $crate::layout::WgslStruct for $rust {
            const WGSL_NAME: &'static str = [$($wgsl,)? stringify!($rust)][0];
            const FIELDS: &'static [$crate::layout::GpuField] = &[
                $($crate::layout::GpuField {
                    name: [$($member,)? stringify!($field)][0],
                    rust_name: stringify!($field),
                    offset: ::core::mem::offset_of!($rust, $field),
                    size: $crate::layout::field_size(|s: &$rust| &s.$field),
                    wgsl_type: $ty,
                    rust_matches: $crate::layout::field_matcher(|s: &$rust| &s.$field),
                    rust_type: $crate::layout::field_type_name(|s: &$rust| &s.$field),
                },)*
            ];
        }

        impl $crate::layout::WgslType for $rust {
            fn matches_wgsl(wgsl: &str) -> bool {
                wgsl == <Self as $crate::layout::WgslStruct>::WGSL_NAME
            }
        }
    };
}

/// Compares the WGSL struct [`WgslStruct::WGSL_NAME`] in `source` with its Rust twin `T`,
/// member by member: the same number of members, and for each the same name, byte offset
/// (`offset_of!` on the Rust side), size and type (the table's WGSL type equals naga's, and
/// the Rust field's type can stand for it, [`WgslType`]); the same total size; and a table
/// that covers every byte of `T` (so no Rust field is missing from it: a `bytemuck::Pod`
/// struct has no padding). A field added, removed, swapped or retyped on either side fails.
///
/// Returns every difference found, one per line.
pub fn check_wgsl_layout<T: WgslStruct>(source: &str) -> Result<(), String> {
    let name = T::WGSL_NAME;
    let Some((span, members)) = reflect(source, name) else {
        return Err(format!(
            "struct {name}: not found (or the WGSL does not parse: validate it first)"
        ));
    };
    let mut errors = Vec::new();
    let rust_size = size_of::<T>();
    if span as usize != rust_size {
        errors.push(format!(
            "size: WGSL {span} bytes, Rust {rust_size} ({})",
            core::any::type_name::<T>()
        ));
    }
    let covered: usize = T::FIELDS.iter().map(|f| f.size).sum();
    if covered != rust_size {
        errors.push(format!(
            "the table's fields cover {covered} of the Rust struct's {rust_size} bytes: every field must be listed"
        ));
    }
    for pair in T::FIELDS.windows(2) {
        if pair[0].offset + pair[0].size > pair[1].offset {
            errors.push(format!(
                "Rust fields `{}` (offset {}) and `{}` (offset {}) are listed out of order or overlap",
                pair[0].rust_name, pair[0].offset, pair[1].rust_name, pair[1].offset
            ));
        }
    }
    if members.len() != T::FIELDS.len() {
        errors.push(format!(
            "WGSL has {} members, the Rust table {} fields",
            members.len(),
            T::FIELDS.len()
        ));
    }
    for (i, (m, f)) in members.iter().zip(T::FIELDS).enumerate() {
        let at = format!("member {i} (WGSL `{}`, Rust `{}`)", m.name, f.rust_name);
        if m.name != f.name {
            errors.push(format!(
                "{at}: the WGSL name is `{}`, the table says `{}`",
                m.name, f.name
            ));
        }
        if m.offset as usize != f.offset {
            errors.push(format!(
                "{at}: offset {} in WGSL, {} in Rust",
                m.offset, f.offset
            ));
        }
        if m.size as usize != f.size {
            errors.push(format!(
                "{at}: {} bytes in WGSL, {} in Rust",
                m.size, f.size
            ));
        }
        if m.ty != f.wgsl_type {
            errors.push(format!(
                "{at}: WGSL type `{}`, the table says `{}`",
                m.ty, f.wgsl_type
            ));
        }
        if !(f.rust_matches)(&m.ty) {
            errors.push(format!(
                "{at}: the Rust type `{}` cannot stand for WGSL `{}`",
                (f.rust_type)(),
                m.ty
            ));
        }
    }
    if errors.is_empty() {
        Ok(())
    } else {
        Err(format!("struct {name}:\n  {}", errors.join("\n  ")))
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[repr(C)]
    #[derive(Clone, Copy, Debug, Default, bytemuck::Pod, bytemuck::Zeroable)]
    struct Inner {
        a: [f32; 3],
        b: u32,
    }
    crate::wgsl_layout!(Inner {
        a: "vec3<f32>",
        b: "u32",
    });

    #[repr(C)]
    #[derive(Clone, Copy, Debug, Default, bytemuck::Pod, bytemuck::Zeroable)]
    struct Outer {
        m: [[f32; 4]; 4],
        rows: [[f32; 4]; 2],
        inner: Inner,
        k1: f32,
        k2: f32,
        id: u32,
        filter: i32,
    }
    crate::wgsl_layout!(Outer as "Shared" {
        m: "mat4x4<f32>",
        rows: "array<vec4<f32>, 2>",
        inner: "Inner",
        k1: "f32",
        k2: "f32",
        id: "u32",
        filter as "search_filter": "i32",
    });

    const INNER: &str = "struct Inner { a: vec3<f32>, b: u32 }\n";
    const GOOD: &str = "struct Shared { m: mat4x4<f32>, rows: array<vec4<f32>, 2>, inner: Inner, \
                        k1: f32, k2: f32, id: u32, search_filter: i32 }";

    fn check(shared: &str) -> Result<(), String> {
        check_wgsl_layout::<Outer>(&format!("{INNER}{shared}"))
    }

    #[test]
    fn reflection_names_offsets_and_types() {
        let m = wgsl_struct_layout(&format!("{INNER}{GOOD}"), "Shared").unwrap();
        let got: Vec<(&str, u32, u32, &str)> = m
            .iter()
            .map(|m| (m.name.as_str(), m.offset, m.size, m.ty.as_str()))
            .collect();
        assert_eq!(
            got,
            [
                ("m", 0, 64, "mat4x4<f32>"),
                ("rows", 64, 32, "array<vec4<f32>, 2>"),
                ("inner", 96, 16, "Inner"),
                ("k1", 112, 4, "f32"),
                ("k2", 116, 4, "f32"),
                ("id", 120, 4, "u32"),
                ("search_filter", 124, 4, "i32"),
            ]
        );
        assert_eq!(wgsl_struct_layout(INNER, "Missing"), None);
        assert_eq!(wgsl_struct_layout("struct (", "Inner"), None);
        assert_eq!(Outer::WGSL_NAME, "Shared");
        assert_eq!(Outer::FIELDS[6].name, "search_filter");
        assert_eq!(Outer::FIELDS[6].rust_name, "filter");
        assert_eq!(Outer::FIELDS[3].offset, 112);
    }

    #[test]
    fn matching_layouts_pass() {
        check(GOOD).unwrap();
        check_wgsl_layout::<Inner>(INNER).unwrap();
    }

    #[test]
    fn swapped_equal_sized_members_fail() {
        // The sizes agree (wgsl_struct_size cannot tell), the layouts do not.
        let swapped = GOOD.replace("k1: f32, k2: f32", "k2: f32, k1: f32");
        let src = format!("{INNER}{swapped}");
        assert_eq!(
            crate::wgsl_struct_size(&src, "Shared"),
            Some(size_of::<Outer>() as u32)
        );
        let err = check(&swapped).unwrap_err();
        assert!(
            err.contains("the WGSL name is `k2`, the table says `k1`"),
            "{err}"
        );
    }

    #[test]
    fn retyped_members_fail_on_either_side() {
        // WGSL says u32 where the table and Rust say f32.
        let err = check(&GOOD.replace("k2: f32", "k2: u32")).unwrap_err();
        assert!(
            err.contains("WGSL type `u32`, the table says `f32`"),
            "{err}"
        );
        assert!(
            err.contains("the Rust type `f32` cannot stand for WGSL `u32`"),
            "{err}"
        );
        // A matrix read as an array of vectors: the same bytes, another type.
        let err = check(&GOOD.replace("m: mat4x4<f32>", "m: array<vec4<f32>, 4>")).unwrap_err();
        assert!(err.contains("the table says `mat4x4<f32>`"), "{err}");
        // A nested struct of another name.
        let src = format!(
            "struct Other {{ a: vec3<f32>, b: u32 }}\n{}",
            GOOD.replace("inner: Inner", "inner: Other")
        );
        assert!(check_wgsl_layout::<Outer>(&src).is_err());
    }

    #[test]
    fn added_or_missing_members_fail() {
        let err = check(&GOOD.replace("search_filter: i32 }", "search_filter: i32, extra: u32 }"))
            .unwrap_err();
        assert!(
            err.contains("WGSL has 8 members, the Rust table 7 fields"),
            "{err}"
        );
        assert!(check(&GOOD.replace(", search_filter: i32", "")).is_err());
        assert!(
            check_wgsl_layout::<Outer>(INNER)
                .unwrap_err()
                .contains("not found")
        );
    }

    /// A table that leaves a Rust field out is caught by the bytes it covers.
    #[test]
    fn a_table_missing_a_rust_field_fails() {
        #[repr(C)]
        #[derive(Clone, Copy, bytemuck::Pod, bytemuck::Zeroable)]
        struct Two {
            a: f32,
            b: f32,
        }
        crate::wgsl_layout!(Two { a: "f32" });
        let err = check_wgsl_layout::<Two>("struct Two { a: f32 }").unwrap_err();
        assert!(
            err.contains("cover 4 of the Rust struct's 8 bytes"),
            "{err}"
        );
    }

    #[test]
    fn rust_types_match_wgsl_spellings() {
        assert!(<[f32; 3]>::matches_wgsl("vec3<f32>"));
        assert!(<[f32; 3]>::matches_wgsl("array<f32, 3>"));
        assert!(!<[f32; 3]>::matches_wgsl("vec3<u32>"));
        assert!(!<[f32; 3]>::matches_wgsl("vec4<f32>"));
        assert!(<[i32; 4]>::matches_wgsl("vec4<i32>"));
        assert!(<[[f32; 4]; 5]>::matches_wgsl("array<vec4<f32>, 5>"));
        assert!(<[[f32; 3]; 4]>::matches_wgsl("mat4x3<f32>"));
        assert!(!<[[f32; 3]; 4]>::matches_wgsl("mat3x4<f32>"));
        assert!(<[[f32; 4]; 4]>::matches_wgsl("array<array<f32, 4>, 4>"));
        assert!(u32::matches_wgsl("atomic<u32>"));
        assert!(!u32::matches_wgsl("f32"));
        assert!(!<[[f32; 1]; 3]>::matches_wgsl("vec3<f32>"));
        assert!(Inner::matches_wgsl("Inner"));
        assert!(!Inner::matches_wgsl("Outer"));
    }
}
