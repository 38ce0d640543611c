//! numpy arrays as volumes. The last three axes are (z, y, x), the spacing in the same order
//! (napari's `scale`); leading axes are channels (`channel_axis=`) and time. A C-ordered
//! (z, y, x) block is exactly voxscope's x-fastest voxels, so each channel is quantized
//! straight from the array's memory, with the GIL released; any other layout (Fortran order,
//! a strided view) is first copied into C order, one pass over the channel drawn. dtypes:
//! u8 i8 u16 i16 u32 i32 f32 f64 as they are; bool, 64-bit integers and float16 are converted
//! (a copy; 64-bit integers to 32 bits where their values fit, else float64).

use numpy::ndarray::{ArrayView3, Axis, Ix3};
use numpy::{Element, PyArrayDyn, PyArrayMethods, PyUntypedArray, PyUntypedArrayMethods};
use pyo3::exceptions::{PyTypeError, PyValueError};
use pyo3::prelude::*;

use voxscope_scene::Channel;
use voxscope_volume::{
    Orientation, QuantizedVolume, Scalar, Selection, Series, ValueScale, Volume, VoxelData,
};

/// How to read an array: its voxel size and which of its leading axes is what.
#[derive(Debug, Clone)]
pub struct ArrayOptions {
    /// Voxel size along x, y, z (given in z, y, x order).
    pub spacing: [f64; 3],
    /// The leading axis holding channels, if any (the other leading axis is time).
    pub channel_axis: Option<isize>,
    /// One channel, or `None` for every channel (the composite of 2 to 8).
    pub channel: Option<usize>,
    /// The time point.
    pub time: usize,
    /// What messages and the app call the array.
    pub name: String,
}

/// The axes of an array of `ndim` dimensions: channels and time among the leading ones.
#[derive(Debug, Clone, Copy)]
struct Layout {
    channel_axis: Option<usize>,
    time_axis: Option<usize>,
}

impl Layout {
    fn of(ndim: usize, channel_axis: Option<isize>) -> PyResult<Self> {
        let leading = match ndim {
            3..=5 => ndim - 3,
            _ => {
                return Err(PyValueError::new_err(format!(
                    "an array of {ndim} dimensions is not a volume: voxscope draws (z, y, x) arrays, with channels and time as leading axes"
                )));
            }
        };
        let channel_axis = match channel_axis {
            None => None,
            Some(axis) => {
                let resolved = if axis < 0 { axis + ndim as isize } else { axis };
                if !(0..leading as isize).contains(&resolved) {
                    return Err(PyValueError::new_err(format!(
                        "channel_axis={axis} is not a leading axis of a {ndim}-D array (the last three are z, y, x{})",
                        if leading == 0 {
                            ""
                        } else {
                            "; leading axes: 0"
                        }
                    )));
                }
                Some(resolved as usize)
            }
        };
        let others: Vec<usize> = (0..leading).filter(|&a| Some(a) != channel_axis).collect();
        match others[..] {
            [] => Ok(Self {
                channel_axis,
                time_axis: None,
            }),
            [time] => Ok(Self {
                channel_axis,
                time_axis: Some(time),
            }),
            _ => Err(PyValueError::new_err(format!(
                "a {ndim}-D array needs channel_axis= (0 or 1): the other leading axis is time"
            ))),
        }
    }
}

/// `data` as an array of a type voxscope stores (converted where it is not one: a copy).
pub fn supported_array<'py>(data: &Bound<'py, PyAny>) -> PyResult<Bound<'py, PyUntypedArray>> {
    let py = data.py();
    let numpy = py.import("numpy")?;
    let array = numpy.call_method1("asarray", (data,))?;
    let dtype = array.getattr("dtype")?;
    let kind: String = dtype.getattr("kind")?.extract()?;
    let size: usize = dtype.getattr("itemsize")?.extract()?;
    let native: bool = dtype.getattr("isnative")?.extract()?;
    let fits = |low: &str, high: &str| -> PyResult<bool> {
        if array.getattr("size")?.extract::<usize>()? == 0 {
            return Ok(true);
        }
        let info = numpy.call_method1("iinfo", (low,))?;
        let min = array.call_method0("min")?;
        let max = array.call_method0("max")?;
        let above: bool = min.ge(info.getattr("min")?)?;
        let info = numpy.call_method1("iinfo", (high,))?;
        let below: bool = max.le(info.getattr("max")?)?;
        Ok(above && below)
    };
    let target = match (kind.as_str(), size) {
        ("b", _) => Some("uint8"),
        ("i" | "u", 1 | 2 | 4) | ("f", 4 | 8) if native => None,
        ("i", 1) => Some("int8"),
        ("i", 2) => Some("int16"),
        ("i", 4) => Some("int32"),
        ("u", 1) => Some("uint8"),
        ("u", 2) => Some("uint16"),
        ("u", 4) => Some("uint32"),
        ("f", 4) => Some("float32"),
        ("f", 2) => Some("float32"),
        ("f", 8) => Some("float64"),
        ("f", _) => Some("float64"),
        ("i", 8) if fits("int32", "int32")? => Some("int32"),
        ("u", 8) if fits("uint32", "uint32")? => Some("uint32"),
        ("i" | "u", 8) => Some("float64"),
        _ => {
            return Err(PyTypeError::new_err(format!(
                "arrays of {} are not volumes: voxscope draws real numbers (uint8, int8, uint16, int16, uint32, int32, float32, float64; bool, 64-bit integers and float16 are converted)",
                dtype.str()?
            )));
        }
    };
    let array = match target {
        Some(target) => array.call_method1("astype", (target,))?,
        None => array,
    };
    Ok(array.cast_into::<PyUntypedArray>()?)
}

/// Quantizes the channels of `array` that `options` choose at its time point.
pub fn quantize(
    array: &Bound<'_, PyUntypedArray>,
    options: &ArrayOptions,
) -> PyResult<Vec<Channel>> {
    macro_rules! typed {
        ($($t:ty),*) => {
            $(
                if let Ok(typed) = array.cast::<PyArrayDyn<$t>>() {
                    return quantize_typed::<$t>(typed, options);
                }
            )*
        };
    }
    typed!(u8, i8, u16, i16, u32, i32, f32, f64);
    Err(PyTypeError::new_err(format!(
        "{}: the array's dtype {} is not one voxscope stores",
        options.name,
        array.dtype()
    )))
}

fn quantize_typed<T: Element + Scalar>(
    array: &Bound<'_, PyArrayDyn<T>>,
    options: &ArrayOptions,
) -> PyResult<Vec<Channel>> {
    let shape = array.shape().to_vec();
    let layout = Layout::of(shape.len(), options.channel_axis)?;
    let channels = layout.channel_axis.map_or(1, |a| shape[a]);
    let time_points = layout.time_axis.map_or(1, |a| shape[a]);
    if options.time >= time_points {
        return Err(PyValueError::new_err(format!(
            "{}: time {} is beyond its {time_points} time points (0 to {})",
            options.name,
            options.time,
            time_points - 1
        )));
    }
    let chosen: Vec<usize> = match options.channel {
        Some(channel) if channel >= channels => {
            return Err(PyValueError::new_err(format!(
                "{}: channel {channel} is beyond its {channels} channels (0 to {})",
                options.name,
                channels - 1
            )));
        }
        Some(channel) => vec![channel],
        None => (0..channels).collect(),
    };
    let n = shape.len();
    let dims = [shape[n - 1], shape[n - 2], shape[n - 3]];
    if dims.contains(&0) {
        return Err(PyValueError::new_err(format!(
            "{}: the shape {:?} has an empty axis",
            options.name, shape
        )));
    }
    let readonly = array.try_readonly().map_err(|e| {
        PyValueError::new_err(format!(
            "{}: the array is being written elsewhere: {e}",
            options.name
        ))
    })?;
    let whole = readonly.as_array();
    let mut views: Vec<ArrayView3<'_, T>> = Vec::with_capacity(chosen.len());
    for &channel in &chosen {
        // Remove the later axis first, so the earlier one keeps its index.
        let mut picks: Vec<(usize, usize)> = Vec::new();
        if let Some(axis) = layout.channel_axis {
            picks.push((axis, channel));
        }
        if let Some(axis) = layout.time_axis {
            picks.push((axis, options.time));
        }
        picks.sort_by_key(|&(axis, _)| std::cmp::Reverse(axis));
        let mut view = whole.view();
        for (axis, index) in picks {
            view = view.index_axis_move(Axis(axis), index);
        }
        views.push(
            view.into_dimensionality::<Ix3>()
                .map_err(|e| PyValueError::new_err(format!("{}: {e}", options.name)))?,
        );
    }
    let quantized: Vec<QuantizedVolume> = array.py().detach(|| {
        views
            .iter()
            .map(|view| match view.as_slice() {
                Some(values) => QuantizedVolume::of_values(dims, values, ValueScale::IDENTITY),
                None => {
                    let copy = view.as_standard_layout();
                    let values = copy.as_slice().expect("a standard layout is contiguous");
                    QuantizedVolume::of_values(dims, values, ValueScale::IDENTITY)
                }
            })
            .collect()
    });
    Ok(chosen
        .into_iter()
        .zip(quantized)
        .map(|(channel, quantized)| Channel {
            volume: description::<T>(options, dims, channels, time_points, channel),
            quantized,
        })
        .collect())
}

/// The [`Volume`] that describes channel `channel` of an array (its voxels empty).
fn description<T: Scalar>(
    options: &ArrayOptions,
    dims: [usize; 3],
    channels: usize,
    time_points: usize,
    channel: usize,
) -> Volume {
    Volume {
        name: options.name.clone(),
        format: "NumPy array",
        dims,
        spacing: options.spacing,
        data: T::wrap(Vec::new()),
        value_scale: ValueScale::IDENTITY,
        orientation: Orientation::AsStored,
        metadata: Vec::new(),
        default_window: None,
        series: Series::plain(
            channels,
            time_points,
            Selection {
                channel,
                time: options.time,
            },
        ),
    }
}

/// A volume's voxels as a numpy array (z, y, x) in the data's units: the stored type where
/// the values are stored as they are, else float32 (8- and 16-bit integers) or float64.
pub fn to_numpy<'py>(py: Python<'py>, volume: &Volume) -> PyResult<Bound<'py, PyAny>> {
    let [x, y, z] = volume.dims;
    let scale = volume.value_scale;
    macro_rules! wrap {
        ($values:expr) => {{
            let values = $values;
            numpy::PyArray1::from_vec(py, values)
                .reshape([z, y, x])
                .map(Bound::into_any)
        }};
    }
    if scale == ValueScale::IDENTITY {
        return match &volume.data {
            VoxelData::U8(v) => wrap!(v.clone()),
            VoxelData::I8(v) => wrap!(v.clone()),
            VoxelData::U16(v) => wrap!(v.clone()),
            VoxelData::I16(v) => wrap!(v.clone()),
            VoxelData::U32(v) => wrap!(v.clone()),
            VoxelData::I32(v) => wrap!(v.clone()),
            VoxelData::F32(v) => wrap!(v.clone()),
            VoxelData::F64(v) => wrap!(v.clone()),
        };
    }
    let small = matches!(
        volume.data,
        VoxelData::U8(_) | VoxelData::I8(_) | VoxelData::U16(_) | VoxelData::I16(_)
    );
    let scaled = (0..volume.data.len()).map(|i| scale.apply(volume.data.get(i).unwrap_or(0.0)));
    if small {
        wrap!(scaled.map(|v| v as f32).collect::<Vec<f32>>())
    } else {
        wrap!(scaled.collect::<Vec<f64>>())
    }
}

/// The numpy dtype name of what [`to_numpy`] gives for `volume`.
pub fn numpy_dtype(volume: &Volume) -> &'static str {
    if volume.value_scale != ValueScale::IDENTITY {
        return match volume.data {
            VoxelData::U8(_) | VoxelData::I8(_) | VoxelData::U16(_) | VoxelData::I16(_) => {
                "float32"
            }
            _ => "float64",
        };
    }
    match volume.data {
        VoxelData::U8(_) => "uint8",
        VoxelData::I8(_) => "int8",
        VoxelData::U16(_) => "uint16",
        VoxelData::I16(_) => "int16",
        VoxelData::U32(_) => "uint32",
        VoxelData::I32(_) => "int32",
        VoxelData::F32(_) => "float32",
        VoxelData::F64(_) => "float64",
    }
}

/// The voxel size of `spacing=` (z, y, x; one number for all three; `None`: 1) along x, y, z.
pub fn spacing_of(value: Option<&Bound<'_, PyAny>>) -> PyResult<[f64; 3]> {
    let Some(value) = value.filter(|v| !v.is_none()) else {
        return Ok([1.0; 3]);
    };
    let zyx: [f64; 3] = match value.extract::<f64>() {
        Ok(one) => [one; 3],
        Err(_) => value
            .extract::<Vec<f64>>()
            .ok()
            .and_then(|v| v.try_into().ok())
            .ok_or_else(|| {
                PyTypeError::new_err(format!(
                    "spacing= takes (sz, sy, sx) or one number, not {}",
                    value.repr().map(|r| r.to_string()).unwrap_or_default()
                ))
            })?,
    };
    if zyx.iter().any(|v| !v.is_finite() || *v <= 0.0) {
        return Err(PyValueError::new_err(format!(
            "spacing ({:?}, {:?}, {:?}) needs three positive numbers",
            zyx[0], zyx[1], zyx[2]
        )));
    }
    Ok([zyx[2], zyx[1], zyx[0]])
}
