//! End-to-end tests: the real stage binaries run by the real runner on small real
//! inputs in a temporary directory. One test binary, topic modules.

mod util;

mod bad_inputs;
mod bvh_pipeline;
mod cdp;
mod default_pipeline;
mod external_rig;
mod face_capture;
mod gplvm_stage;
mod init;
mod invrig;
mod lifetime;
mod live;
mod partitions;
mod pipeline_errors;
mod provenance_checks;
mod python_readers;
mod replay;
mod retarget;
mod robot_pipeline;
mod scale_pca;
mod slurm;
