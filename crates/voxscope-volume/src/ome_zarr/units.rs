//! Unit names as OME-Zarr writes them (`micrometer`), from what files and loaders say (`um`,
//! `µm`, `Å`): one table for every reader and for `convert`.

/// The OME-Zarr name of the unit `text` names, if it is a length unit voxscope knows.
pub(crate) fn ome_unit(text: &str) -> Option<&'static str> {
    Some(match text.trim() {
        "m" | "meter" | "metre" => "meter",
        "cm" | "centimeter" | "centimetre" => "centimeter",
        "mm" | "millimeter" | "millimetre" => "millimeter",
        "um" | "µm" | "μm" | "micron" | "microns" | "micrometer" | "micrometre" => "micrometer",
        "nm" | "nanometer" | "nanometre" => "nanometer",
        "pm" | "picometer" | "picometre" => "picometer",
        "Å" | "A" | "angstrom" => "angstrom",
        _ => return None,
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn abbreviations_become_ome_names() {
        assert_eq!(ome_unit(" um "), Some("micrometer"));
        assert_eq!(ome_unit("Å"), Some("angstrom"));
        assert_eq!(ome_unit("furlong"), None);
    }
}
