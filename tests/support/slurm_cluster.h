// SPDX-License-Identifier: Apache-2.0
#pragma once
// A single-node Slurm cluster for the tests: Debian's munged, slurmctld and
// slurmd (packages munge and slurm-wlm) started on this machine by the test,
// with everything of theirs in the test's folder: a munge key and socket of
// its own, free ports, state and logs, the current user as Slurm's user. The
// clients (sbatch, squeue, scontrol) find it through SLURM_CONF, which
// environment() sets. Stopped, and every daemon ended, with the object.

#include "free_port.h"
#include "run_command.h"

#include <pwd.h>
#include <signal.h>
#include <sys/stat.h>
#include <unistd.h>

#include <chrono>
#include <filesystem>
#include <fstream>
#include <random>
#include <stdexcept>
#include <string>
#include <thread>

namespace lfi::testing_support {

class SlurmCluster {
 public:
  // Whether this machine has the programs.
  static bool available() {
    for (const char* p : {"/usr/sbin/munged", "/usr/sbin/slurmctld", "/usr/sbin/slurmd", "/usr/bin/sbatch"})
      if (::access(p, X_OK) != 0) return false;
    return true;
  }

  explicit SlurmCluster(std::filesystem::path folder) : folder_(std::move(folder)) {
    namespace fs = std::filesystem;
    for (const char* d : {"munge", "state", "spool", "log"}) fs::create_directories(folder_ / d);
    // munged wants its key the user's alone and its folders not writable by others.
    {
      std::ofstream key(folder_ / "munge" / "munge.key", std::ios::binary);
      std::mt19937_64 random(std::random_device{}());
      for (int i = 0; i < 128; ++i) {
        const std::uint64_t word = random();
        key.write(reinterpret_cast<const char*>(&word), sizeof word);
      }
    }
    ::chmod((folder_ / "munge").c_str(), 0700);
    ::chmod((folder_ / "munge" / "munge.key").c_str(), 0400);
    const std::string munge = (folder_ / "munge").string();
    run("/usr/sbin/munged -f --socket=" + munge + "/socket --key-file=" + munge + "/munge.key --log-file=" + munge +
        "/munged.log --pid-file=" + munge + "/munged.pid --seed-file=" + munge + "/seed");

    char host[256] = {};
    ::gethostname(host, sizeof host - 1);
    std::string node = host;
    node = node.substr(0, node.find('.'));
    const passwd* user = ::getpwuid(::geteuid());
    const std::string name = user ? user->pw_name : "root";
    const std::string f = folder_.string();
    std::ofstream(folder_ / "slurm.conf")
        << "ClusterName=lfitest\nSlurmctldHost=" << node << "(127.0.0.1)\n"
        << "SlurmctldPort=" << freeLoopbackPort() << "\nSlurmdPort=" << freeLoopbackPort() << "\n"
        << "AuthType=auth/munge\nAuthInfo=socket=" << munge << "/socket\nCredType=cred/munge\n"
        << "SlurmUser=" << name << "\nSlurmdUser=" << name << "\n"
        << "StateSaveLocation=" << f << "/state\nSlurmdSpoolDir=" << f << "/spool\n"
        << "SlurmctldPidFile=" << f << "/slurmctld.pid\nSlurmdPidFile=" << f << "/slurmd.pid\n"
        << "SlurmctldLogFile=" << f << "/log/slurmctld.log\nSlurmdLogFile=" << f << "/log/slurmd.log\n"
        << "ProctrackType=proctrack/linuxproc\nTaskPlugin=task/none\nSwitchType=switch/none\nMpiDefault=none\n"
        << "ReturnToService=2\nSchedulerType=sched/backfill\nSelectType=select/cons_tres\n"
        << "SelectTypeParameters=CR_Core\nJobCompType=jobcomp/none\nAccountingStorageType=accounting_storage/none\n"
        << "JobAcctGatherType=jobacct_gather/none\nKillWait=5\nMinJobAge=600\nInactiveLimit=0\n"
        << "NodeName=" << node << " NodeAddr=127.0.0.1 CPUs=" << std::max(1u, std::thread::hardware_concurrency())
        << " State=UNKNOWN\nPartitionName=test Nodes=" << node << " Default=YES MaxTime=INFINITE State=UP\n";
    run(environment() + "/usr/sbin/slurmctld -f " + f + "/slurm.conf");
    run(environment() + "/usr/sbin/slurmd -f " + f + "/slurm.conf");
    // Up when the node takes jobs.
    const auto deadline = std::chrono::steady_clock::now() + std::chrono::seconds(30);
    while (runCommand(environment() + "sinfo -h -o %T 2>/dev/null").output.find("idle") == std::string::npos) {
      if (std::chrono::steady_clock::now() > deadline)
        throw std::runtime_error("the Slurm node is not idle after 30 s; see " + f + "/log");
      std::this_thread::sleep_for(std::chrono::milliseconds(100));
    }
  }

  ~SlurmCluster() {
    runCommand(environment() + "scontrol shutdown >/dev/null 2>&1");
    for (const char* pidFile : {"slurmctld.pid", "slurmd.pid", "munge/munged.pid"}) end(folder_ / pidFile);
  }
  SlurmCluster(const SlurmCluster&) = delete;
  SlurmCluster& operator=(const SlurmCluster&) = delete;

  // "SLURM_CONF=<its file> ", to put before a client command.
  std::string environment() const { return "SLURM_CONF=" + shellQuoted((folder_ / "slurm.conf").string()) + " "; }
  const std::filesystem::path& folder() const { return folder_; }

 private:
  static void run(const std::string& command) {
    const CommandResult r = runCommand(command + " 2>&1");
    if (r.status != 0) throw std::runtime_error(command + " failed: " + r.output);
  }

  // The daemon of a pid file, asked to end and then made to (5 s later).
  static void end(const std::filesystem::path& pidFile) {
    std::ifstream in(pidFile);
    pid_t pid = 0;
    if (!(in >> pid) || pid <= 0) return;
    ::kill(pid, SIGTERM);
    const auto deadline = std::chrono::steady_clock::now() + std::chrono::seconds(5);
    while (::kill(pid, 0) == 0 && std::chrono::steady_clock::now() < deadline)
      std::this_thread::sleep_for(std::chrono::milliseconds(50));
    ::kill(pid, SIGKILL);
  }

  std::filesystem::path folder_;
};

}  // namespace lfi::testing_support
