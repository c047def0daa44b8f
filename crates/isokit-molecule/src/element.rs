//! Chemical elements with the radii and colours a molecular viewer or surface builder needs.

use std::fmt;

/// Covalent radius given to [`Element::Unknown`], in Å.
pub const UNKNOWN_COVALENT_RADIUS: f32 = 1.5;
/// Van der Waals radius given to [`Element::Unknown`], in Å.
pub const UNKNOWN_VDW_RADIUS: f32 = 1.8;

/// Defines [`Element`] and its per-element data from one table, so that symbol, name,
/// radii and colour can never drift apart.
macro_rules! elements {
    ($( $var:ident = $z:literal, $sym:literal, $name:literal, $cov:literal, $vdw:literal, $rgb:literal; )*) => {
        /// A chemical element: H–U (Z = 1–92) except promethium (which none of the
        /// van der Waals tables below covers), plus [`Element::Unknown`].
        ///
        /// Data, all in Å:
        /// - [`Element::covalent_radius`]: single-bond covalent radii of B. Cordero,
        ///   V. Gómez, A. E. Platero-Prats, M. Revés, J. Echeverría, E. Cremades,
        ///   F. Barragán and S. Alvarez, "Covalent radii revisited", *Dalton Trans.*
        ///   2008, 2832–2838, doi:10.1039/b801115j. Carbon takes the sp³ value (0.76);
        ///   Mn, Fe and Co take the low-spin values (1.39, 1.32, 1.26).
        /// - [`Element::vdw_radius`]: A. Bondi, "van der Waals volumes and radii",
        ///   *J. Phys. Chem.* 68 (1964) 441–451, doi:10.1021/j100785a001, where Bondi gives
        ///   one (H 1.20, C 1.70, N 1.55, O 1.52, S 1.80, …); for the main-group elements
        ///   Bondi lacks (Be, B, Al, Ca, Ge, Rb, Sr, Sb, Cs, Ba, Bi, Po, At, Rn, Fr, Ra),
        ///   M. Mantina, A. C. Chamberlin, R. Valero, C. J. Cramer and D. G. Truhlar,
        ///   "Consistent van der Waals radii for the whole main group", *J. Phys. Chem. A*
        ///   113 (2009) 5806–5812, doi:10.1021/jp8111556; for the remaining transition
        ///   metals, lanthanides and actinides, S. Alvarez, "A cartography of the van der
        ///   Waals territories", *Dalton Trans.* 42 (2013) 8617–8636,
        ///   doi:10.1039/c3dt50599e.
        /// - [`Element::cpk_color`]: Jmol's default CPK colour table (the "ghemical"
        ///   colours with Jmol's modifications, <https://jmol.sourceforge.net/jscolors/>).
        ///
        /// [`Element::Unknown`] has covalent radius [`UNKNOWN_COVALENT_RADIUS`] (1.5 Å),
        /// van der Waals radius [`UNKNOWN_VDW_RADIUS`] (1.8 Å), symbol `"X"` and Jmol's
        /// colour for unknown atoms, deep pink (`#FF1493`).
        #[derive(Clone, Copy, Debug, PartialEq, Eq, Hash, PartialOrd, Ord, Default)]
        #[non_exhaustive]
        #[repr(u8)]
        pub enum Element {
            /// An element this crate does not know, or none given.
            #[default]
            Unknown = 0,
            $(
                #[doc = concat!($name, " (", $sym, ", Z = ", stringify!($z), ").")]
                $var = $z,
            )*
        }

        /// Every known element in order of atomic number (without [`Element::Unknown`]).
        const ALL: &[Element] = &[$(Element::$var,)*];

        /// `(symbol, atomic number)` for the symbol lookup table.
        const SYMBOLS: &[(&str, u8)] = &[$(($sym, $z),)*];

        impl Element {
            /// The element with atomic number `z`, or [`Element::Unknown`] (also for 0 and
            /// for promethium, 61).
            pub fn from_atomic_number(z: u8) -> Element {
                match z {
                    $($z => Element::$var,)*
                    _ => Element::Unknown,
                }
            }

            /// The symbol with its usual capitalisation (`"C"`, `"Fe"`); `"X"` for
            /// [`Element::Unknown`].
            pub fn symbol(self) -> &'static str {
                match self {
                    $(Element::$var => $sym,)*
                    Element::Unknown => "X",
                }
            }

            /// The English name in lower case (`"carbon"`); `"unknown"` for
            /// [`Element::Unknown`].
            pub fn name(self) -> &'static str {
                match self {
                    $(Element::$var => $name,)*
                    Element::Unknown => "unknown",
                }
            }

            /// Single-bond covalent radius in Å (Cordero et al. 2008; see [`Element`]);
            /// [`UNKNOWN_COVALENT_RADIUS`] for [`Element::Unknown`].
            pub fn covalent_radius(self) -> f32 {
                match self {
                    $(Element::$var => $cov,)*
                    Element::Unknown => UNKNOWN_COVALENT_RADIUS,
                }
            }

            /// Van der Waals radius in Å (Bondi 1964, else Mantina et al. 2009, else
            /// Alvarez 2013; see [`Element`]); [`UNKNOWN_VDW_RADIUS`] for
            /// [`Element::Unknown`].
            pub fn vdw_radius(self) -> f32 {
                match self {
                    $(Element::$var => $vdw,)*
                    Element::Unknown => UNKNOWN_VDW_RADIUS,
                }
            }

            /// Jmol's CPK colour as 8-bit sRGB, exactly as Jmol's table gives it (e.g.
            /// carbon `[0x90, 0x90, 0x90]`); deep pink `[0xFF, 0x14, 0x93]` for
            /// [`Element::Unknown`].
            pub fn cpk_color_srgb8(self) -> [u8; 3] {
                let rgb: u32 = match self {
                    $(Element::$var => $rgb,)*
                    Element::Unknown => 0xFF1493,
                };
                [(rgb >> 16) as u8, (rgb >> 8) as u8, rgb as u8]
            }
        }
    };
}

// Z, symbol, name, covalent radius (Cordero 2008), van der Waals radius with its source
// (B = Bondi 1964, M = Mantina 2009, A = Alvarez 2013), Jmol colour.
elements! {
    H = 1, "H", "hydrogen", 0.31, 1.20, 0xFFFFFF; // B
    He = 2, "He", "helium", 0.28, 1.40, 0xD9FFFF; // B
    Li = 3, "Li", "lithium", 1.28, 1.82, 0xCC80FF; // B
    Be = 4, "Be", "beryllium", 0.96, 1.53, 0xC2FF00; // M
    B = 5, "B", "boron", 0.84, 1.92, 0xFFB5B5; // M
    C = 6, "C", "carbon", 0.76, 1.70, 0x909090; // B
    N = 7, "N", "nitrogen", 0.71, 1.55, 0x3050F8; // B
    O = 8, "O", "oxygen", 0.66, 1.52, 0xFF0D0D; // B
    F = 9, "F", "fluorine", 0.57, 1.47, 0x90E050; // B
    Ne = 10, "Ne", "neon", 0.58, 1.54, 0xB3E3F5; // B
    Na = 11, "Na", "sodium", 1.66, 2.27, 0xAB5CF2; // B
    Mg = 12, "Mg", "magnesium", 1.41, 1.73, 0x8AFF00; // B
    Al = 13, "Al", "aluminium", 1.21, 1.84, 0xBFA6A6; // M
    Si = 14, "Si", "silicon", 1.11, 2.10, 0xF0C8A0; // B
    P = 15, "P", "phosphorus", 1.07, 1.80, 0xFF8000; // B
    S = 16, "S", "sulfur", 1.05, 1.80, 0xFFFF30; // B
    Cl = 17, "Cl", "chlorine", 1.02, 1.75, 0x1FF01F; // B
    Ar = 18, "Ar", "argon", 1.06, 1.88, 0x80D1E3; // B
    K = 19, "K", "potassium", 2.03, 2.75, 0x8F40D4; // B
    Ca = 20, "Ca", "calcium", 1.76, 2.31, 0x3DFF00; // M
    Sc = 21, "Sc", "scandium", 1.70, 2.58, 0xE6E6E6; // A
    Ti = 22, "Ti", "titanium", 1.60, 2.46, 0xBFC2C7; // A
    V = 23, "V", "vanadium", 1.53, 2.42, 0xA6A6AB; // A
    Cr = 24, "Cr", "chromium", 1.39, 2.45, 0x8A99C7; // A
    Mn = 25, "Mn", "manganese", 1.39, 2.45, 0x9C7AC7; // A
    Fe = 26, "Fe", "iron", 1.32, 2.44, 0xE06633; // A
    Co = 27, "Co", "cobalt", 1.26, 2.40, 0xF090A0; // A
    Ni = 28, "Ni", "nickel", 1.24, 1.63, 0x50D050; // B
    Cu = 29, "Cu", "copper", 1.32, 1.40, 0xC88033; // B
    Zn = 30, "Zn", "zinc", 1.22, 1.39, 0x7D80B0; // B
    Ga = 31, "Ga", "gallium", 1.22, 1.87, 0xC28F8F; // B
    Ge = 32, "Ge", "germanium", 1.20, 2.11, 0x668F8F; // M
    As = 33, "As", "arsenic", 1.19, 1.85, 0xBD80E3; // B
    Se = 34, "Se", "selenium", 1.20, 1.90, 0xFFA100; // B
    Br = 35, "Br", "bromine", 1.20, 1.85, 0xA62929; // B
    Kr = 36, "Kr", "krypton", 1.16, 2.02, 0x5CB8D1; // B
    Rb = 37, "Rb", "rubidium", 2.20, 3.03, 0x702EB0; // M
    Sr = 38, "Sr", "strontium", 1.95, 2.49, 0x00FF00; // M
    Y = 39, "Y", "yttrium", 1.90, 2.75, 0x94FFFF; // A
    Zr = 40, "Zr", "zirconium", 1.75, 2.52, 0x94E0E0; // A
    Nb = 41, "Nb", "niobium", 1.64, 2.56, 0x73C2C9; // A
    Mo = 42, "Mo", "molybdenum", 1.54, 2.45, 0x54B5B5; // A
    Tc = 43, "Tc", "technetium", 1.47, 2.44, 0x3B9E9E; // A
    Ru = 44, "Ru", "ruthenium", 1.46, 2.46, 0x248F8F; // A
    Rh = 45, "Rh", "rhodium", 1.42, 2.44, 0x0A7D8C; // A
    Pd = 46, "Pd", "palladium", 1.39, 1.63, 0x006985; // B
    Ag = 47, "Ag", "silver", 1.45, 1.72, 0xC0C0C0; // B
    Cd = 48, "Cd", "cadmium", 1.44, 1.58, 0xFFD98F; // B
    In = 49, "In", "indium", 1.42, 1.93, 0xA67573; // B
    Sn = 50, "Sn", "tin", 1.39, 2.17, 0x668080; // B
    Sb = 51, "Sb", "antimony", 1.39, 2.06, 0x9E63B5; // M
    Te = 52, "Te", "tellurium", 1.38, 2.06, 0xD47A00; // B
    I = 53, "I", "iodine", 1.39, 1.98, 0x940094; // B
    Xe = 54, "Xe", "xenon", 1.40, 2.16, 0x429EB0; // B
    Cs = 55, "Cs", "caesium", 2.44, 3.43, 0x57178F; // M
    Ba = 56, "Ba", "barium", 2.15, 2.68, 0x00C900; // M
    La = 57, "La", "lanthanum", 2.07, 2.98, 0x70D4FF; // A
    Ce = 58, "Ce", "cerium", 2.04, 2.88, 0xFFFFC7; // A
    Pr = 59, "Pr", "praseodymium", 2.03, 2.92, 0xD9FFC7; // A
    Nd = 60, "Nd", "neodymium", 2.01, 2.95, 0xC7FFC7; // A
    Sm = 62, "Sm", "samarium", 1.98, 2.90, 0x8FFFC7; // A
    Eu = 63, "Eu", "europium", 1.98, 2.87, 0x61FFC7; // A
    Gd = 64, "Gd", "gadolinium", 1.96, 2.83, 0x45FFC7; // A
    Tb = 65, "Tb", "terbium", 1.94, 2.79, 0x30FFC7; // A
    Dy = 66, "Dy", "dysprosium", 1.92, 2.87, 0x1FFFC7; // A
    Ho = 67, "Ho", "holmium", 1.92, 2.81, 0x00FF9C; // A
    Er = 68, "Er", "erbium", 1.89, 2.83, 0x00E675; // A
    Tm = 69, "Tm", "thulium", 1.90, 2.79, 0x00D452; // A
    Yb = 70, "Yb", "ytterbium", 1.87, 2.80, 0x00BF38; // A
    Lu = 71, "Lu", "lutetium", 1.87, 2.74, 0x00AB24; // A
    Hf = 72, "Hf", "hafnium", 1.75, 2.63, 0x4DC2FF; // A
    Ta = 73, "Ta", "tantalum", 1.70, 2.53, 0x4DA6FF; // A
    W = 74, "W", "tungsten", 1.62, 2.57, 0x2194D6; // A
    Re = 75, "Re", "rhenium", 1.51, 2.49, 0x267DAB; // A
    Os = 76, "Os", "osmium", 1.44, 2.48, 0x266696; // A
    Ir = 77, "Ir", "iridium", 1.41, 2.41, 0x175487; // A
    Pt = 78, "Pt", "platinum", 1.36, 1.72, 0xD0D0E0; // B
    Au = 79, "Au", "gold", 1.36, 1.66, 0xFFD123; // B
    Hg = 80, "Hg", "mercury", 1.32, 1.55, 0xB8B8D0; // B
    Tl = 81, "Tl", "thallium", 1.45, 1.96, 0xA6544D; // B
    Pb = 82, "Pb", "lead", 1.46, 2.02, 0x575961; // B
    Bi = 83, "Bi", "bismuth", 1.48, 2.07, 0x9E4FB5; // M
    Po = 84, "Po", "polonium", 1.40, 1.97, 0xAB5C00; // M
    At = 85, "At", "astatine", 1.50, 2.02, 0x754F45; // M
    Rn = 86, "Rn", "radon", 1.50, 2.20, 0x428296; // M
    Fr = 87, "Fr", "francium", 2.60, 3.48, 0x420066; // M
    Ra = 88, "Ra", "radium", 2.21, 2.83, 0x007D00; // M
    Ac = 89, "Ac", "actinium", 2.15, 2.80, 0x70ABFA; // A
    Th = 90, "Th", "thorium", 2.06, 2.93, 0x00BAFF; // A
    Pa = 91, "Pa", "protactinium", 2.00, 2.88, 0x00A1FF; // A
    U = 92, "U", "uranium", 1.96, 1.86, 0x008FFF; // B
}

/// Slot of a one- or two-letter symbol (upper-cased) in [`LOOKUP`]: 26 first letters × 27
/// (no second letter, or A–Z).
const fn slot(first: u8, second: Option<u8>) -> usize {
    let a = (first - b'A') as usize;
    let b = match second {
        None => 0,
        Some(c) => (c - b'A') as usize + 1,
    };
    a * 27 + b
}

/// Atomic number by symbol slot (0 = none), built at compile time from [`SYMBOLS`].
const LOOKUP: [u8; 26 * 27] = {
    let mut t = [0u8; 26 * 27];
    let mut i = 0;
    while i < SYMBOLS.len() {
        let (sym, z) = SYMBOLS[i];
        let b = sym.as_bytes();
        let second = if b.len() > 1 {
            Some(b[1].to_ascii_uppercase())
        } else {
            None
        };
        t[slot(b[0].to_ascii_uppercase(), second)] = z;
        i += 1;
    }
    t
};

impl Element {
    /// Every known element in order of atomic number (without [`Element::Unknown`]).
    pub fn all() -> &'static [Element] {
        ALL
    }

    /// The element for a symbol, case-insensitively and ignoring surrounding whitespace:
    /// `"Fe"`, `"FE"`, `" fe"` are all iron. Deuterium `"D"` and tritium `"T"` count as
    /// hydrogen. Anything else (empty, unknown, longer than two letters) is
    /// [`Element::Unknown`].
    ///
    /// ```
    /// use isokit_molecule::Element;
    /// assert_eq!(Element::from_symbol("FE"), Element::Fe);
    /// assert_eq!(Element::from_symbol(" c"), Element::C);
    /// assert_eq!(Element::from_symbol("Xx"), Element::Unknown);
    /// ```
    pub fn from_symbol(symbol: &str) -> Element {
        let b = symbol.trim().as_bytes();
        let up = |c: u8| c.is_ascii_alphabetic().then(|| c.to_ascii_uppercase());
        let s = match b {
            [a] => up(*a).map(|a| slot(a, None)),
            [a, c] => match (up(*a), up(*c)) {
                (Some(a), Some(c)) => Some(slot(a, Some(c))),
                _ => None,
            },
            _ => None,
        };
        match s {
            Some(s) if s == slot(b'D', None) || s == slot(b'T', None) => Element::H,
            Some(s) => Element::from_atomic_number(LOOKUP[s]),
            None => Element::Unknown,
        }
    }

    /// The atomic number (0 for [`Element::Unknown`]).
    pub fn atomic_number(self) -> u8 {
        self as u8
    }

    /// Jmol's CPK colour (see [`Element`]) converted from sRGB to *linear* RGB in 0..=1,
    /// ready for lighting and blending (write it out through [`isokit_io::linear_to_srgb8`]
    /// to get Jmol's 8-bit value back). Carbon is about `[0.279, 0.279, 0.279]` here,
    /// `0x90 / 255 = 0.565` in sRGB; use [`Element::cpk_color_srgb8`] for the values as
    /// Jmol lists them.
    pub fn cpk_color(self) -> [f32; 3] {
        self.cpk_color_srgb8().map(isokit_io::srgb8_to_linear)
    }
}

impl fmt::Display for Element {
    /// Writes the symbol.
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.write_str(self.symbol())
    }
}
