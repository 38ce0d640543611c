//! Python keywords as the command line's options: each rendering keyword is the `render`
//! option of the same name (`opacity_points=` is `--opacity-points`), written as the option's
//! text and read by the parser that option uses (`voxscope_scene::option_text`) into the
//! scene layer's [`DrawOptions`] and [`OpenOptions`], the model the command line maps into
//! too (`convert()`'s into [`ConvertOptions`]). So a keyword means what its option means,
//! takes its defaults and its checks, and a bad value raises the option's one-line message.
//!
//! Values: a string is the option's text as typed on the command line (in its x, y, z
//! order); numbers, booleans, tuples and lists are written for it, tuples of axes in numpy's
//! (z, y, x) order (`spacing`, `clip_box`, `clip_plane`), as the arrays are.

use pyo3::exceptions::{PyTypeError, PyValueError};
use pyo3::prelude::*;
use pyo3::types::{PyDict, PyString};
use voxscope_scene::{ConvertOptions, DrawOptions, OpenOptions};

use crate::keyword_values::{set_convert_option, set_open_option, set_option};

/// How a keyword's Python value becomes command-line words.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Form {
    /// One value, written as Python's `str()` of it (a number, a name, a path).
    Value,
    /// Two numbers joined by `separator` (`window=(0, 255)` is `0:255`, `size` `1024x768`).
    Pair(&'static str),
    /// `True` adds the flag, `False` nothing.
    Flag,
    /// `True` adds `--NAME`, `False` adds `--no-NAME` (`shading`).
    Switch,
    /// `False` adds `--no-NAME`, `True` nothing (`opacity_correction`).
    NegatedFlag,
    /// (value, opacity) pairs: `V:A,V:A,…` (`opacity_points`).
    Points,
    /// ((z0, z1), (y0, y1), (x0, x1)): `X0:X1,Y0:Y1,Z0:Z1`.
    ClipBox,
    /// (nz, ny, nx, d): `NX,NY,NZ,D`.
    ClipPlane,
    /// (sz, sy, sx), or one number for all three: `SX,SY,SZ`.
    Spacing,
    /// (x, y, z) counts, or one number: `X,Y,Z` (`convert`'s `tile` and `upsample`).
    Triple,
    /// Names, `#rrggbb` or (r, g, b) triples: `C0,C1,…` (`channel_colors`).
    Colors,
    /// {channel: (low, high)} or (channel, low, high) triples: one `N:LOW:HIGH` each
    /// (`channel_window`).
    ChannelWindows,
    /// Whole numbers, or one: `N,N,…` (`channels`).
    Indices,
    /// Names or numbers, or one: `A,B,…` (`labels`, `labels_hide`).
    List,
}

/// A keyword and the option it stands for.
#[derive(Debug, Clone, Copy)]
pub struct Keyword {
    pub name: &'static str,
    pub form: Form,
    /// The option's value name in its messages (`--preset <NAME>`); empty for a flag.
    pub value: &'static str,
}

const fn keyword(name: &'static str, form: Form) -> Keyword {
    Keyword {
        name,
        form,
        value: "",
    }
}

/// Keyword `name` of `table` as the command line shows its option: `--name <VALUE>`, or
/// `--name` for a flag.
pub(crate) fn shown(table: &[Keyword], name: &str) -> String {
    let flag = format!("--{}", name.replace('_', "-"));
    match table.iter().find(|k| k.name == name) {
        Some(keyword) if !keyword.value.is_empty() => format!("{flag} <{}>", keyword.value),
        _ => flag,
    }
}

/// A keyword whose option's value is called `value` in messages (`--size <SIZE>`).
const fn valued(name: &'static str, form: Form, value: &'static str) -> Keyword {
    Keyword { name, form, value }
}

/// The keywords that choose the transfer function: any of them replaces the others given
/// before (a frame's `preset=` replaces the Renderer's `opacity=`), as they conflict.
pub const TRANSFER_CHOICE: [&str; 4] = ["opacity", "opacity_points", "preset", "tf"];

/// Keywords fixed when a [`crate::renderer::Renderer`] is made (they choose what is uploaded).
pub const STRUCTURAL: [&str; 10] = [
    "renderer",
    "labels",
    "labels_opacity",
    "labels_hide",
    "brick_size",
    "gpu_memory",
    "ram_cache",
    "upload_budget",
    "lod_scale",
    "uploads",
];

/// Keywords that change neither the transfer function nor the channels' tables.
const VIEW_ONLY: [&str; 6] = [
    "azimuth",
    "elevation",
    "distance",
    "fov",
    "size",
    "max_wait",
];

/// `render`'s options but the volume and the output: what `render()`, `Renderer()` and
/// `Renderer.render()` take.
pub const RENDER: &[Keyword] = &[
    valued("mode", Form::Value, "MODE"),
    valued("opacity", Form::Value, "OPACITY"),
    valued("opacity_points", Form::Points, "V:A,…"),
    valued("preset", Form::Value, "NAME"),
    valued("tf", Form::Value, "FILE.ron"),
    valued("threshold", Form::Value, "THRESHOLD"),
    valued("window", Form::Pair(":"), "LOW:HIGH"),
    valued("colormap", Form::Value, "COLORMAP"),
    valued("density", Form::Value, "DENSITY"),
    valued("level", Form::Value, "LEVEL"),
    keyword("pixel_lod", Form::Flag),
    keyword("opacity_correction", Form::NegatedFlag),
    keyword("heatmap", Form::Flag),
    keyword("nearest", Form::Flag),
    keyword("shading", Form::Switch),
    valued("ambient", Form::Value, "AMBIENT"),
    valued("diffuse", Form::Value, "DIFFUSE"),
    valued("specular", Form::Value, "SPECULAR"),
    valued("shininess", Form::Value, "SHININESS"),
    valued("clip_box", Form::ClipBox, "X0:X1,Y0:Y1,Z0:Z1"),
    valued("clip_plane", Form::ClipPlane, "NX,NY,NZ,D"),
    valued("channel_colors", Form::Colors, "C0,C1,…"),
    valued("channel_window", Form::ChannelWindows, "N:LOW:HIGH"),
    valued("channels", Form::Indices, "N,N,…"),
    valued("labels", Form::List, "NAME|FILE"),
    valued("labels_opacity", Form::Value, "F"),
    valued("labels_hide", Form::List, "V,…"),
    valued("renderer", Form::Value, "RENDERER"),
    valued("brick_size", Form::Value, "BRICK_SIZE"),
    valued("gpu_memory", Form::Value, "SIZE"),
    valued("ram_cache", Form::Value, "SIZE"),
    valued("upload_budget", Form::Value, "SIZE"),
    valued("uploads", Form::Value, "PATH"),
    valued("lod_scale", Form::Value, "F"),
    valued("max_wait", Form::Value, "SECONDS"),
    valued("size", Form::Pair("x"), "SIZE"),
    valued("azimuth", Form::Value, "AZIMUTH"),
    valued("elevation", Form::Value, "ELEVATION"),
    valued("distance", Form::Value, "DISTANCE"),
    valued("fov", Form::Value, "FOV"),
];

/// What opens a path or URL: `open()`'s keywords (the command line's volume options).
pub const OPEN: &[Keyword] = &[
    valued("raw", Form::Value, "LAYOUT"),
    valued("spacing", Form::Spacing, "SX,SY,SZ"),
    valued("channel", Form::Value, "N|all"),
    valued("time", Form::Value, "TIME"),
    valued("max_requests", Form::Value, "N"),
];

/// `convert()`'s keywords: `convert`'s options but the input and output.
pub const CONVERT: &[Keyword] = &[
    valued("raw", Form::Value, "LAYOUT"),
    valued("spacing", Form::Spacing, "SX,SY,SZ"),
    valued("channel", Form::Value, "CHANNEL"),
    valued("time", Form::Value, "TIME"),
    valued("max_requests", Form::Value, "N"),
    valued("format", Form::Value, "FORMAT"),
    valued("chunk", Form::Value, "CHUNK"),
    valued("shard", Form::Value, "SHARD"),
    valued("compression", Form::Value, "COMPRESSION"),
    keyword("labels", Form::Flag),
    valued("unit", Form::Value, "UNIT"),
    valued("tile", Form::Triple, "N|X,Y,Z"),
    valued("upsample", Form::Triple, "N|X,Y,Z"),
    valued("noise", Form::Value, "NOISE"),
];

/// Keywords given to a call, each already written as its command-line words, in the order
/// given.
#[derive(Debug, Clone, Default, PartialEq)]
pub struct Given {
    pub words: Vec<(&'static str, Vec<String>)>,
}

impl Given {
    /// Reads `kwargs` against `table`; `function` names the call in a wrong keyword's
    /// TypeError, as Python does.
    pub fn read(
        kwargs: Option<&Bound<'_, PyDict>>,
        table: &[Keyword],
        function: &str,
    ) -> PyResult<Self> {
        let mut words = Vec::new();
        for (key, value) in kwargs.into_iter().flatten() {
            let key: String = key.extract()?;
            let keyword = table.iter().find(|k| k.name == key).ok_or_else(|| {
                let names: Vec<&str> = table.iter().map(|k| k.name).collect();
                PyTypeError::new_err(format!(
                    "{function}() got an unexpected keyword argument '{key}' (it takes {})",
                    names.join(", ")
                ))
            })?;
            if value.is_none() {
                continue;
            }
            words.push((keyword.name, write(keyword, &value)?));
        }
        Ok(Self { words })
    }

    /// These keywords with `later`'s on top: a keyword given again takes its new value, and
    /// a new transfer choice (`preset`, `opacity`, …) drops the old one.
    pub fn with(&self, later: &Given) -> Given {
        let replaces_choice = later
            .words
            .iter()
            .any(|(name, _)| TRANSFER_CHOICE.contains(name));
        let mut words: Vec<_> = self
            .words
            .iter()
            .filter(|(name, _)| {
                let given_again = later.words.iter().any(|(n, _)| n == name);
                let choice_replaced = replaces_choice && TRANSFER_CHOICE.contains(name);
                !given_again && !choice_replaced
            })
            .cloned()
            .collect();
        words.extend(later.words.iter().cloned());
        Given { words }
    }

    /// The first of `names` given, if any.
    pub fn any_of(&self, names: &[&str]) -> Option<&'static str> {
        self.words
            .iter()
            .map(|(name, _)| *name)
            .find(|name| names.contains(name))
    }

    /// The words of the keywords that decide the transfer function and the channels' tables
    /// (all but the camera, size and `max_wait`): what changes them.
    pub fn transfer_words(&self) -> Vec<String> {
        self.words
            .iter()
            .filter(|(name, _)| !VIEW_ONLY.contains(name))
            .flat_map(|(_, words)| words.iter().cloned())
            .collect()
    }

    /// Every word, in order.
    pub fn argv(&self) -> Vec<String> {
        self.words
            .iter()
            .flat_map(|(_, words)| words.iter().cloned())
            .collect()
    }

    /// What these keywords ask of the drawing (the rest at `render`'s defaults): each
    /// keyword's text read by the parser its `render` option uses (`voxscope_scene::
    /// option_text`); a bad value is a ValueError naming the keyword.
    pub fn draw_options(&self) -> PyResult<DrawOptions> {
        let choices: Vec<&str> = self
            .words
            .iter()
            .map(|(name, _)| *name)
            .filter(|name| TRANSFER_CHOICE.contains(name))
            .collect();
        if let [first, second, ..] = choices[..] {
            return Err(PyValueError::new_err(format!(
                "the argument '{}' cannot be used with '{}'",
                shown(RENDER, first),
                shown(RENDER, second)
            )));
        }
        let mut options = DrawOptions::default();
        for (name, words) in &self.words {
            for word in words {
                set_option(&mut options, name, word)
                    .map_err(|e| PyValueError::new_err(e.message(&shown(RENDER, name))))?;
            }
        }
        Ok(options)
    }

    /// What opening `spec` with these keywords (`open()`'s) reads.
    pub fn open_options(&self, spec: &str) -> PyResult<OpenOptions> {
        let mut options = OpenOptions {
            source: Some(spec.to_owned()),
            ..OpenOptions::default()
        };
        for (name, words) in &self.words {
            for word in words {
                set_open_option(&mut options, name, word)
                    .map_err(|e| PyValueError::new_err(e.message(&shown(OPEN, name))))?;
            }
        }
        Ok(options)
    }

    /// `convert`'s options with these keywords (`convert()`'s).
    pub fn convert_options(&self) -> PyResult<ConvertOptions> {
        let given = |name| self.words.iter().any(|(n, _)| *n == name);
        for other in ["tile", "labels"] {
            if given("upsample") && given(other) {
                return Err(PyValueError::new_err(format!(
                    "the argument '{}' cannot be used with '{}'",
                    shown(CONVERT, "upsample"),
                    shown(CONVERT, other)
                )));
            }
        }
        if given("noise") && !given("upsample") {
            return Err(PyValueError::new_err(format!(
                "noise= needs upsample= (the argument '{}' requires '{}')",
                shown(CONVERT, "noise"),
                shown(CONVERT, "upsample")
            )));
        }
        let mut options = ConvertOptions::default();
        for (name, words) in &self.words {
            for word in words {
                set_convert_option(&mut options, name, word)
                    .map_err(|e| PyValueError::new_err(e.message(&shown(CONVERT, name))))?;
            }
        }
        Ok(options)
    }
}

/// The words of `keyword` = `value`.
fn write(keyword: &Keyword, value: &Bound<'_, PyAny>) -> PyResult<Vec<String>> {
    let option = format!("--{}", keyword.name.replace('_', "-"));
    let single = |text: String| Ok(vec![format!("{option}={text}")]);
    // A string is the option's text, as typed on the command line.
    if let Ok(text) = value.cast::<PyString>() {
        let text = text.to_cow()?.into_owned();
        return match keyword.form {
            Form::Flag | Form::Switch | Form::NegatedFlag => Err(PyTypeError::new_err(format!(
                "{}= takes True or False, not '{text}'",
                keyword.name
            ))),
            Form::ChannelWindows => Ok(text
                .split(';')
                .map(|w| format!("{option}={}", w.trim()))
                .collect()),
            _ => single(text),
        };
    }
    match keyword.form {
        Form::Value => single(value.str()?.to_string()),
        Form::Pair(separator) => {
            let [a, b] = numbers::<2>(keyword.name, value)?;
            single(format!("{a}{separator}{b}"))
        }
        Form::Flag => Ok(if boolean(keyword.name, value)? {
            vec![option]
        } else {
            Vec::new()
        }),
        Form::Switch => Ok(if boolean(keyword.name, value)? {
            vec![option]
        } else {
            vec![format!("--no-{}", keyword.name.replace('_', "-"))]
        }),
        Form::NegatedFlag => Ok(if boolean(keyword.name, value)? {
            Vec::new()
        } else {
            vec![format!("--no-{}", keyword.name.replace('_', "-"))]
        }),
        Form::Points => {
            let mut points = Vec::new();
            for point in value.try_iter()? {
                let [v, a] = numbers::<2>(keyword.name, &point?)?;
                points.push(format!("{v}:{a}"));
            }
            single(points.join(","))
        }
        Form::ClipBox => {
            let mut ranges = Vec::new();
            for range in value.try_iter()? {
                let [low, high] = numbers::<2>(keyword.name, &range?)?;
                ranges.push(format!("{low}:{high}"));
            }
            if ranges.len() != 3 {
                return Err(PyValueError::new_err(format!(
                    "clip_box= takes three (low, high) pairs in (z, y, x) order, not {}",
                    ranges.len()
                )));
            }
            ranges.reverse();
            single(ranges.join(","))
        }
        Form::ClipPlane => {
            let [nz, ny, nx, d] = numbers::<4>(keyword.name, value)?;
            single(format!("{nx},{ny},{nz},{d}"))
        }
        Form::Spacing => {
            if let Ok(one) = value.extract::<f64>() {
                return single(format!("{one},{one},{one}"));
            }
            let [z, y, x] = numbers::<3>(keyword.name, value)?;
            single(format!("{x},{y},{z}"))
        }
        Form::Indices => {
            if let Ok(one) = value.extract::<u64>() {
                return single(one.to_string());
            }
            let mut indices = Vec::new();
            for index in value.try_iter()? {
                indices.push(index?.extract::<u64>().map_err(|_| {
                    PyTypeError::new_err(format!(
                        "{}= takes channel numbers (whole numbers from 0)",
                        keyword.name
                    ))
                })?);
            }
            single(
                indices
                    .iter()
                    .map(u64::to_string)
                    .collect::<Vec<_>>()
                    .join(","),
            )
        }
        Form::List => {
            if value.extract::<f64>().is_ok() {
                return single(value.str()?.to_string());
            }
            let mut items = Vec::new();
            for item in value.try_iter()? {
                items.push(item?.str()?.to_string());
            }
            single(items.join(","))
        }
        Form::Triple => {
            if let Ok(one) = value.extract::<i64>() {
                return single(one.to_string());
            }
            let [x, y, z] = numbers::<3>(keyword.name, value)?;
            single(format!("{x},{y},{z}"))
        }
        Form::Colors => {
            let mut colors = Vec::new();
            for color in value.try_iter()? {
                let color = color?;
                colors.push(match color.extract::<String>() {
                    Ok(name) => name,
                    Err(_) => {
                        let rgb: [u8; 3] = color.extract().map_err(|_| {
                            PyTypeError::new_err(
                                "channel_colors= takes names, '#rrggbb' or (r, g, b) triples of 0…255",
                            )
                        })?;
                        format!("#{:02x}{:02x}{:02x}", rgb[0], rgb[1], rgb[2])
                    }
                });
            }
            single(colors.join(","))
        }
        Form::ChannelWindows => {
            let entries: Vec<(String, String, String)> = if let Ok(map) = value.cast::<PyDict>() {
                map.iter()
                    .map(|(channel, window)| {
                        let [low, high] = numbers::<2>(keyword.name, &window)?;
                        Ok((channel.str()?.to_string(), low, high))
                    })
                    .collect::<PyResult<_>>()?
            } else {
                value
                    .try_iter()?
                    .map(|entry| {
                        let [channel, low, high] = numbers::<3>(keyword.name, &entry?)?;
                        Ok((channel, low, high))
                    })
                    .collect::<PyResult<_>>()?
            };
            Ok(entries
                .into_iter()
                .map(|(channel, low, high)| format!("{option}={channel}:{low}:{high}"))
                .collect())
        }
    }
}

/// `True` or `False` (numbers are refused: `shading=0` is more likely a mistake).
fn boolean(name: &str, value: &Bound<'_, PyAny>) -> PyResult<bool> {
    value
        .extract::<bool>()
        .map_err(|_| PyTypeError::new_err(format!("{name}= takes True or False")))
}

/// Exactly `N` numbers (a tuple, list or array), each written as Python's `str()` of it.
fn numbers<const N: usize>(name: &str, value: &Bound<'_, PyAny>) -> PyResult<[String; N]> {
    let wrong = || {
        PyTypeError::new_err(format!(
            "{name}= takes {N} numbers, not {}",
            value
                .repr()
                .map(|r| r.to_string())
                .unwrap_or_else(|_| "this".into())
        ))
    };
    let items: Vec<Bound<'_, PyAny>> = value
        .try_iter()
        .map_err(|_| wrong())?
        .collect::<PyResult<_>>()?;
    if items.len() != N {
        return Err(wrong());
    }
    let mut texts = Vec::with_capacity(N);
    for item in &items {
        // Numbers only; numpy scalars pass through float().
        let number: f64 = item.extract().map_err(|_| wrong())?;
        texts.push(if number.fract() == 0.0 && number.abs() < 1e15 {
            format!("{}", number as i64)
        } else {
            item.str()?.to_string()
        });
    }
    texts.try_into().map_err(|_| wrong())
}
