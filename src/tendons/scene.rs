//! Building the readings solve from a scene: the scene layer describes the problem,
//! the solver builds itself from it.

use super::TendonWorkspace;
use crate::error::ModelError;
use crate::scene::Scene;

impl TendonWorkspace {
    /// A workspace that solves `scene` from actuator readings (the scene needs
    /// displacement-driven tendons): reference solve at the pretensions included.
    pub fn from_scene(scene: &Scene) -> Result<Self, ModelError> {
        Self::new(
            scene.build_robot()?,
            scene.loads.clone(),
            scene.numerics.clone(),
        )
    }
}

impl Scene {
    /// A workspace that solves this scene from actuator readings:
    /// [`TendonWorkspace::from_scene`].
    pub fn tendon_workspace(&self) -> Result<TendonWorkspace, ModelError> {
        TendonWorkspace::from_scene(self)
    }
}
