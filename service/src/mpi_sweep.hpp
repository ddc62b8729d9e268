#pragma once
// Sweeps over MPI ranks (docs/cluster.md): `mpirun -np N runout sweep SWEEP.json --db runout.db`.
//
// Rank 0 is the coordinator: it owns the run store (the only rank that opens it), skips the runs already
// stored (resume), hands out the others largest predicted cost first (sweep_cost.hpp), receives each run's
// record (metrics.json text and series CSVs, as JSON) and stores it with put_run, and prints the progress
// lines. Ranks >= 1 are workers: they run one run at a time with their OpenMP threads through execute_run
// (study.hpp), the same code run_and_store uses, and send the record back. With -np 1 rank 0 runs the sweep
// itself (run_sweep, as without mpirun).
//
// Failure of a worker: every worker sends a heartbeat each second (from a thread of its own, so a long scene
// build or step does not silence it). A worker not heard from for --heartbeat-timeout seconds is declared
// lost and its run goes back to the front of the queue for another worker (rank 0 runs it itself when no
// worker is left). Open MPI 4.1 has no ULFM, so rank 0 learns of a dead rank only by this silence, and mpirun
// must be told not to abort the job when a rank dies: `mpirun --enable-recovery` (or the MCA parameter
// orte_enable_recovery=1). Without it mpirun kills every rank when one dies; the store keeps every run that
// was finished and the same command resumes.
//
// mpi.h stays out of this header: cmd_sweep.cpp includes it whether or not the build has MPI.
#include <atomic>
#include <cstdlib>
#include <memory>
#include <string>

#include "runout/scenarios/store.hpp"
#include "runout/scenarios/study.hpp"

namespace runout::cluster {

// Whether this process was started by an MPI launcher, read from the environment so that a plain
// `runout sweep` never initialises MPI: Open MPI's mpirun/mpiexec (OMPI_COMM_WORLD_SIZE), PMI-2 launchers
// such as Slurm's `srun --mpi=pmi2` and MPICH (PMI_SIZE), PMIx launchers such as `srun --mpi=pmix` (PMIX_RANK).
inline bool launched_by_mpi() {
  return std::getenv("OMPI_COMM_WORLD_SIZE") || std::getenv("PMI_SIZE") || std::getenv("PMIX_RANK");
}
// The job's size when the launcher says it (0: unknown), for refusing `mpirun -np 4` of a build without MPI.
inline int launcher_world_size() {
  for (const char* name : {"OMPI_COMM_WORLD_SIZE", "PMI_SIZE"})
    if (const char* v = std::getenv(name)) return std::atoi(v);
  return 0;
}

struct MpiSweepOptions {
  double heartbeat_timeout = 60;  // [s] without a word from a worker before it is declared lost
  int threads = 0;                // OpenMP threads per run on a worker; 0: see MpiWorld::default_threads
};

// MPI for one sweep: MPI_Init_thread (MPI_THREAD_SERIALIZED: a worker's heartbeat thread and its main thread
// take turns under a mutex) in the constructor; errors return codes instead of aborting the job.
class MpiWorld {
 public:
  MpiWorld();
  ~MpiWorld();  // MPI_Finalize, when finish() has not run
  MpiWorld(const MpiWorld&) = delete;
  MpiWorld& operator=(const MpiWorld&) = delete;

  int rank() const { return rank_; }
  int size() const { return size_; }
  // OpenMP threads of one run on this rank: OMP_NUM_THREADS when set (0: OpenMP's default honours it); the
  // rank's CPU set when the launcher bound it to fewer CPUs than the node has (srun --cpus-per-task, mpirun
  // --bind-to); otherwise the node's CPUs divided among the ranks that compute on it (rank 0 only coordinates
  // when there are workers).
  int default_threads() const { return default_threads_; }

  // A rank is gone: on rank 0 a worker declared dead after its silence; on a worker, rank 0 said so in its
  // shutdown message, or went silent itself.
  void set_peer_lost() { peer_lost_ = true; }
  bool peer_lost() const { return peer_lost_; }

  // Ends MPI and returns `code`. When a rank was lost it does not call MPI_Finalize, which waits for every
  // rank (a dead or hung one would keep it waiting for ever, and mpirun with it): it flushes stdout and
  // stderr and ends the process here with `code`. The caller must have closed the run store first (its last transaction is
  // committed and fsync'd by then, so nothing is lost).
  int finish(int code);

 private:
  int rank_ = 0, size_ = 1, default_threads_ = 0;
  bool peer_lost_ = false, finished_ = false;
};

// Rank 0 before any work (a refused sweep, a store that does not open): tells every worker to exit.
void release_workers(MpiWorld& world);

// Ranks >= 1: run what rank 0 hands out until it says stop. `stop` (SIGINT/SIGTERM) stops the current run,
// which is sent back as "stopped" (stored as a single-process sweep stores it). Returns the exit code: 0, or
// 1 when rank 0 fell silent for the heartbeat timeout.
int run_worker(MpiWorld& world, const MpiSweepOptions& options, const std::atomic<bool>* stop);

// Rank 0 with workers (size >= 2): the whole sweep, as run_sweep does it single-process, with the same events
// (options.on_event) and result; options.jobs and options.threads are not used (each worker runs one run at a
// time with its own threads). The record of every run is what run_and_store would store.
SweepResult coordinate_sweep(MpiWorld& world, RunStore& store, const Sweep& sweep, const SweepOptions& options,
                             const MpiSweepOptions& mpi_options);

}  // namespace runout::cluster
