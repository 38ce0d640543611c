"""Type stubs of the extension module (crates/voxscope-python/src). Every rendering keyword is
the `voxscope render` option of the same name; a string value is the option's text as typed on
the command line, tuples of axes are in numpy's (z, y, x) order."""

import os
from typing import Any, Dict, List, Literal, Mapping, Optional, Sequence, Tuple, Union

import numpy as np
import numpy.typing as npt
from typing_extensions import TypedDict, Unpack

__version__: str

_Path = Union[str, "os.PathLike[str]"]
_Pair = Union[Tuple[float, float], Sequence[float], str]
_Bytes = Union[int, str]
_Color = Union[str, Tuple[int, int, int]]
_Image = npt.NDArray[np.uint8]

class RenderOptions(TypedDict, total=False):
    """The keywords of `render()`, `Renderer()` and `Renderer.render()`/`draw()`: `render`'s
    options (docs/cli.md) by the same names."""

    mode: Literal["dvr", "mip"]
    opacity: Literal["gray", "binary"]
    opacity_points: Union[Sequence[Tuple[float, float]], str]
    preset: Literal["ct-soft-tissue", "ct-bone", "ct-vessels", "ct-lung", "ct-skin", "ramp"]
    tf: _Path
    threshold: float
    window: _Pair
    colormap: Literal["grays", "viridis", "inferno", "magma", "plasma", "cividis", "labels"]
    density: float
    level: int
    pixel_lod: bool
    opacity_correction: bool
    heatmap: bool
    nearest: bool
    shading: bool
    ambient: float
    diffuse: float
    specular: float
    shininess: float
    clip_box: Union[Sequence[Tuple[float, float]], str]
    clip_plane: Union[Tuple[float, float, float, float], str]
    channel_colors: Union[Sequence[_Color], str]
    channel_window: Union[Mapping[int, Tuple[float, float]], Sequence[Tuple[int, float, float]], str]
    channels: Union[int, Sequence[int], str]
    labels: Union[str, Sequence[str]]
    labels_opacity: float
    labels_hide: Union[float, Sequence[float], str]
    renderer: Literal["octree", "dense", "bricks", "stream"]
    brick_size: Literal[4, 8, 16, 32]
    gpu_memory: _Bytes
    ram_cache: _Bytes
    upload_budget: _Bytes
    lod_scale: float
    uploads: Literal["scatter", "copies", "queue"]
    max_wait: float
    size: Union[Tuple[int, int], str]
    azimuth: float
    elevation: float
    distance: float
    fov: float

class InputOptions(RenderOptions, total=False):
    """`RenderOptions` and what reads the input: an array's `spacing`, `channel_axis`,
    `channel`, `time`, `name`; a path's `raw`, `spacing`, `channel`, `time`, `max_requests`."""

    spacing: Union[float, Tuple[float, float, float]]
    channel_axis: int
    channel: int
    time: int
    name: str
    raw: str
    max_requests: int

class OpenOptions(TypedDict, total=False):
    """`open()`'s keywords: the command line's volume options."""

    raw: str
    spacing: Union[float, Tuple[float, float, float]]
    channel: int
    time: int
    max_requests: int

class ConvertOptions(TypedDict, total=False):
    """`convert()`'s keywords: `voxscope convert`'s options."""

    raw: str
    spacing: Union[float, Tuple[float, float, float]]
    channel: int
    time: int
    max_requests: int
    format: Literal["0.4", "0.5"]
    chunk: int
    shard: int
    compression: Literal["blosc-lz4", "blosc-zstd", "zstd", "gzip", "none"]
    labels: bool
    unit: str
    tile: Union[int, Tuple[int, int, int]]
    upsample: Union[int, Tuple[int, int, int]]
    noise: float
    name: str

class VoxscopeError(Exception):
    """A voxscope operation failed; the message is the command line's one line for it."""

class LoadError(VoxscopeError):
    """A file, folder, store or URL could not be read."""

class RenderError(VoxscopeError):
    """The GPU could not hold or draw the volume."""

class Volume:
    """A volume opened by `open()`: its facts, and its levels read as numpy arrays."""

    @property
    def source(self) -> str: ...
    @property
    def options(self) -> List[str]: ...
    @property
    def name(self) -> str: ...
    @property
    def format(self) -> str: ...
    @property
    def shape(self) -> Tuple[int, int, int]: ...
    @property
    def dtype(self) -> np.dtype: ...
    @property
    def spacing(self) -> Tuple[float, float, float]: ...
    @property
    def unit(self) -> str: ...
    @property
    def levels(self) -> List[Tuple[int, int, int]]: ...
    @property
    def channels(self) -> List[str]: ...
    @property
    def time_points(self) -> int: ...
    @property
    def selected(self) -> Tuple[int, int]: ...
    def read(
        self, level: int = 0, *, channel: Optional[int] = None, time: Optional[int] = None
    ) -> npt.NDArray: ...

_Data = Union[npt.ArrayLike, Volume, _Path]

class Renderer:
    """A volume resident on the GPU, drawn frame after frame into numpy images."""

    def __init__(self, data: _Data, **options: Unpack[InputOptions]) -> None: ...
    def render(self, **options: Unpack[RenderOptions]) -> _Image: ...
    def draw(self, **options: Unpack[RenderOptions]) -> None: ...
    def finish(self) -> None: ...
    def read(self) -> _Image: ...
    @property
    def kind(self) -> str: ...
    @property
    def name(self) -> str: ...
    @property
    def depth(self) -> int: ...
    @property
    def gpu_bytes(self) -> List[Tuple[str, int]]: ...
    @property
    def device(self) -> str: ...

def render(data: _Data, **options: Unpack[InputOptions]) -> _Image: ...
def open(source: _Path, **options: Unpack[OpenOptions]) -> Volume: ...
def convert(
    source: Union[npt.ArrayLike, Volume, _Path], output: _Path, **options: Unpack[ConvertOptions]
) -> List[Tuple[int, int, int]]: ...
def _convert_plan(
    source: Union[Volume, _Path],
    output: _Path,
    parts: int,
    part_memory: str = "512MiB",
    **options: Unpack[ConvertOptions],
) -> str: ...
def _convert_run_part(plan: _Path, part: int) -> Dict[str, Any]: ...
def _convert_finalize(plan: _Path) -> List[Tuple[int, int, int]]: ...
def device() -> str: ...
def run_command_line(argv: List[str]) -> int: ...
def _voxels(data: npt.ArrayLike) -> npt.NDArray: ...
def _command_line_words(**options: Unpack[RenderOptions]) -> List[str]: ...

