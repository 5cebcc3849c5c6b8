//! The application-level error: one variant per layer, each with its own error type.

/// Everything that can stop a dvsgi command.
#[derive(Debug, thiserror::Error)]
pub enum Error {
    #[error(transparent)]
    Scene(#[from] crate::scene::SceneError),
    #[error(transparent)]
    Gpu(#[from] crate::gpu::GpuError),
    #[error(transparent)]
    Output(#[from] crate::output::OutputError),
    #[error(transparent)]
    Metrics(#[from] crate::metrics::MetricsError),
    #[error(transparent)]
    Plot(#[from] crate::pareto::PlotError),
    #[error(transparent)]
    Sweep(#[from] crate::sweep::SweepError),
    #[error(transparent)]
    View(#[from] crate::view::ViewError),
    #[error(transparent)]
    Model(#[from] crate::model::ModelError),
    /// Vulkan validation reported errors (only when validation is on).
    #[error("Vulkan validation reported {0} error(s); see the messages above")]
    Validation(u32),
    /// Bad command-line usage not caught by the argument parser.
    #[error("{0}")]
    Usage(String),
}

pub type Result<T> = std::result::Result<T, Error>;
