# Sourced by devel/setup.bash: one BLAS thread per process unless the user chose otherwise.
# The nodes do small matrix work at sensor rates (3x3 rotations of a depth image's points, 2x2
# Kalman updates); OpenBLAS's worker threads busy-wait between such calls. Measured on
# user_tracker_ni_node in florence_sim: 37 CPU s in 45 s with OpenBLAS's default threads,
# 5.6 CPU s with one.
OPENBLAS_NUM_THREADS="${OPENBLAS_NUM_THREADS:-1}"
export OPENBLAS_NUM_THREADS
