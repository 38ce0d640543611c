//! The scene layer: everything between a file and a picture that is not a window. Opening a
//! source ([`VolumeSource`]) reads the time point and channels asked for, quantizes them,
//! builds the octree and histogram ([`VolumeData`]), chooses the transfer function the volume
//! opens with ([`opening_transfer`], one rule for the default window and the presets) and
//! makes the renderer ([`Scene`]); a store too large for memory opens streamed
//! ([`StreamedVolume`], refined by [`refine`] where nothing drives frames). Long work runs as
//! a [`Job`] with a [`Progress`] and ends in a typed [`SceneError`] when it does not succeed
//! (cancellation is a variant, not a message). A view is saved and read again as a
//! [`SavedView`]; a movie's frames are [`Shot`]s of a [`turntable`] or a [`keyframe_path`].
//!
//! The app's background jobs, the command line and the Python module all call this crate;
//! nothing here knows of egui.

mod channels;
mod convert;
mod data;
mod drawable;
mod error;
mod job;
mod label_open;
mod label_overlay;
mod movie_path;
mod opening;
pub mod option_text;
mod options;
mod prefetch;
mod prepare;
mod saved_transfer;
mod scene;
mod source;
mod stream_channels;
mod streaming;
mod view;
mod view_v1;

pub use channels::{ChannelRequest, ChannelState, CompositeScene, file_channel_numbers};
pub use convert::{
    ConvertOptions, MAX_PARTS, PART_SLAB_BYTES, PLAN_FOLDER, PartMarker, PartOutcome, Plan,
    PlanOptions, convert, finalize, plan_conversion, run_part,
};
pub use data::{HISTOGRAM_BINS, VolumeData};
pub use drawable::{Channel, Drawable};
pub use error::{LabelError, SceneError};
pub use job::Job;
pub use label_open::{
    LABEL_BUDGET_FLOOR, StreamedLabelLook, label_stream_options, open_overlays,
    open_streamed_label, open_streamed_overlays,
};
pub use label_overlay::{
    DEFAULT_LABEL_OPACITY, LabelLayer, LabelOverlay, MAX_LABEL_VALUES, SlotPass, UploadedLabels,
    blend_slots, label_color, label_pass_settings,
};
pub use movie_path::{Shot, keyframe_channels, keyframe_path, turntable};
pub use opening::{
    TransferChoice, TransferRequest, beyond_octree, default_window, file_window, opening_transfer,
    renderer_for_octree,
};
pub use options::{
    ChannelChoice, DEFAULT_MAX_WAIT_SECONDS, DrawOptions, LabelOptions, OpenOptions,
    TransferOptions,
};
pub use prefetch::{
    DEFAULT_PREFETCH_FRAMES, FrameKey, MAX_PREFETCH_FRAMES, PREFETCH_BYTES, Prefetch,
    frames_within_cap, window,
};
pub use prepare::{FrameChange, Opened, PANEL_LEVEL_VOXELS, prepare_scene};
pub use saved_transfer::{SavedTransfer, TransferFileError};
pub use scene::{
    Counted, NetworkState, OctreeColors, Scene, statistics_job, upload, upload_colored,
};
pub use source::VolumeSource;
pub use stream_channels::{StreamedChannel, StreamedChannels};
pub use streaming::{
    OpenedStream, PREVIEW_BRICKS, REMOTE_WORKERS, Refinement, StreamedVolume,
    describe_budget_limit, describe_missing, refine, stream_options_for,
};
pub use view::{SavedView, VIEW_VERSION, ViewFileError, ViewProblem, ViewRuler};
pub use voxscope_volume::progress::{Cancelled, Progress};
