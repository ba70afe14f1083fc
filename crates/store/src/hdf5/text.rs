//! Text in the file as netCDF's `char` arrays (the UTF-8 bytes of each text along a last
//! dimension `<name>_strlen`, `_Encoding = "utf-8"`), the type CF and its checker accept, written
//! and read checked.

use super::*;

/// One-byte strings, netCDF's `char`: the element type of a text variable's characters.
type Char = hdf5::types::FixedAscii<1>;

/// A text variable written as netCDF's `char` array: its dataset and the name of the dimension of
/// its characters.
pub(crate) struct CharVar {
    /// The dataset, of the text's shape and the characters' dimension last.
    pub data: Dataset,
    /// The characters' dimension (a dimension without a variable).
    pub strlen: String,
}

/// What a text array holds, which says whether deflate pays for it.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub(crate) enum Text {
    /// Free text written at every point (failure reasons, warnings): the same few sentences over
    /// and over, with numbers in them. Deflated, they shrink about 80-fold (the warnings of the
    /// 100 000-run summary bench: 5.4 MB to 90 kB), and read back nearly as fast.
    Free,
    /// Identifiers and short labels (run hashes, probe names, coordinates). A run hash's hex digits
    /// deflate only to about half, and h5py then reads them 9 times slower, so they stay as they are.
    Names,
}

/// Deflate level of [`Text::Free`]: level 1 gives nearly all of what higher levels give on such
/// text (90 kB against 64 kB for the bench's warnings) at the least time.
pub const TEXT_DEFLATE_LEVEL: u8 = 1;

/// Writes the texts `data` (of shape `shape`, row-major) as the netCDF `char` array `name`: the
/// UTF-8 bytes of each text along a last dimension as long as the longest (at least 1), padded
/// with NUL (a NUL inside a text becomes U+FFFD, as in every stored string), chunked with the
/// Fletcher-32 filter like the numbers, with `_Encoding = "utf-8"`. The characters' dimension is a
/// dimension without a variable named `<name>_strlen` (with `_` appended while that name is
/// taken). With `scale`, the array is the scale of dimension `scale` (a text coordinate named like
/// its dimension): a scale takes no scale of its own, so the characters' dimension is recorded in
/// its `_Netcdf4Coordinates` ([`number_dimensions`]); else the characters' dimension's scale is
/// attached to its last dimension, and the caller attaches the others. [`Text::Free`] is deflated
/// as well.
pub(crate) fn char_dataset(
    group: &Group,
    name: &str,
    shape: &[usize],
    data: &[String],
    scale: Option<&str>,
    text: Text,
) -> Result<CharVar> {
    let texts: Vec<Vec<u8>> = data
        .iter()
        .map(|s| s.replace('\0', "\u{FFFD}").into_bytes())
        .collect();
    let len = texts.iter().map(Vec::len).max().unwrap_or(0).max(1);
    let mut bytes = vec![0u8; texts.len() * len];
    for (row, t) in bytes.chunks_mut(len).zip(&texts) {
        row[..t.len()].copy_from_slice(t);
    }
    let strlen = free_name(group, &format!("{name}_strlen"));
    let dim = dimension_only(group, &strlen, len)?;
    let mut full = shape.to_vec();
    full.push(len);
    let mut builder = checked_builder::<Char>(group, &full);
    if text == Text::Free {
        builder = builder.deflate(TEXT_DEFLATE_LEVEL);
    }
    let d = builder
        .shape(full.clone())
        .create(name)
        .map_err(crate::h5)?;
    // In the dataset's own (one-byte string) type, so that HDF5 converts nothing; the chunks of
    // empty texts only (NULs) are left unwritten, as every column's chunks of its fill value.
    let ty = d.dtype().map_err(crate::h5)?;
    if ty.size() != 1 {
        return Err(Error::Other(format!(
            "dataset {} holds no characters",
            d.name()
        )));
    }
    write_points(&d, ty.id(), &full, &bytes, &[0])?;
    match scale {
        Some(dim_name) => set_scale(&d, dim_name)?,
        None => attach_scale(&d, &dim, shape.len(), &strlen)?,
    }
    attr_str(&d, "_Encoding", CHAR_ENCODING)?;
    Ok(CharVar { data: d, strlen })
}

/// Whether `d` holds netCDF `char`s (one-byte strings): text along its last dimension.
pub(crate) fn is_char(d: &Dataset) -> bool {
    use hdf5::types::TypeDescriptor;
    matches!(
        d.dtype().and_then(|t| t.to_descriptor()),
        Ok(TypeDescriptor::FixedAscii(1) | TypeDescriptor::FixedUnicode(1))
    )
}

/// The bytes of every element of the one-byte string dataset `d`, read as stored (in its own
/// type, without HDF5's Fletcher-32 check: a damaged chunk reads as it is, and the checksums of
/// its points say which are damaged).
pub(crate) fn read_chars(d: &Dataset) -> Result<Vec<u8>> {
    let ty = d.dtype().map_err(crate::h5)?;
    if ty.size() != 1 {
        return Err(Error::Other(format!(
            "dataset {} holds no characters",
            d.name()
        )));
    }
    let mut buf = vec![0u8; d.size()];
    read_all_unchecked(d, &ty, &mut buf)?;
    Ok(buf)
}

/// The texts of a text dataset: a netCDF `char` array (layout 4; each text along the last
/// dimension, NUL-padded) or variable-length strings (earlier layouts). Decoded checked ([`text_of`]).
pub(crate) fn read_text(d: &Dataset) -> Result<Vec<String>> {
    if !is_char(d) {
        return Ok(d
            .read_raw::<VarLenUnicode>()
            .map_err(crate::h5)?
            .iter()
            .map(text_of)
            .collect());
    }
    let len = d.shape().last().copied().unwrap_or(1).max(1);
    Ok(read_chars(d)?
        .chunks(len)
        .map(|row| {
            let end = row.iter().rposition(|&b| b != 0).map_or(0, |k| k + 1);
            String::from_utf8_lossy(&row[..end]).into_owned()
        })
        .collect())
}

/// The text of a stored string, decoded checked: invalid UTF-8 (a damaged byte) becomes U+FFFD
/// (the checksums covering the string then report the damage), never undefined behaviour.
pub(crate) fn text_of(v: &VarLenUnicode) -> String {
    String::from_utf8_lossy(v.as_bytes()).into_owned()
}
