// SPDX-License-Identifier: Apache-2.0
#pragma once
// The packets this host's kernel dropped on a GigE Vision stream's way into
// this process over loopback, read from the kernel's own counters, so that a
// streaming test can tell a loss the host made (a receive buffer left full on
// a loaded machine) from one Aravis or lfi made. A stream packet from a device
// on this host can be dropped in three places, each counted by the kernel:
// - loopback's backlog (at most net.core.netdev_max_backlog packets waiting
//   per CPU): the `drop` column of lo in /proc/net/dev (this process's network
//   namespace);
// - Aravis's packet socket, with CAP_NET_RAW (root, as in CI): Aravis reads
//   the stream from an AF_PACKET ring, whose drops the socket's
//   PACKET_STATISTICS count;
// - Aravis's UDP socket, without it: the receive buffer full, the `drops`
//   column of /proc/net/udp for the socket.
// With a packet socket the UDP socket, which nobody reads then, receives the
// stream too and drops nearly all of it once its buffer is full: its drops are
// not the stream's and are not counted.
//
// PACKET_STATISTICS resets the counts it returns; Aravis 0.8 never reads them,
// and one HostDrops sums them, so a test uses one for all its streams.

#include <dirent.h>
#include <linux/if_packet.h>
#include <sys/socket.h>
#include <unistd.h>

#include <cstdint>
#include <cstdlib>
#include <fstream>
#include <map>
#include <set>
#include <sstream>
#include <string>
#include <vector>

namespace lfi::testing_support {

class HostDrops {
 public:
  // The counters' values now: what count() adds up from.
  HostDrops() : loopbackBaseline_(loopbackDrops()), udpBaseline_(udpDrops()) {}

  // Stream packets dropped since construction.
  std::uint64_t count() {
    const std::uint64_t loopback = loopbackDrops() - loopbackBaseline_;
    for (const auto& [inode, fd] : socketFds()) {
      int domain = 0;
      socklen_t size = sizeof domain;
      if (::getsockopt(fd, SOL_SOCKET, SO_DOMAIN, &domain, &size) != 0 || domain != AF_PACKET) continue;
      tpacket_stats_v3 stats{};
      size = sizeof stats;
      if (::getsockopt(fd, SOL_PACKET, PACKET_STATISTICS, &stats, &size) == 0) ringDrops_[inode] += stats.tp_drops;
    }
    std::uint64_t socket = 0;
    if (!ringDrops_.empty()) {
      for (const auto& [inode, drops] : ringDrops_) socket += drops;
    } else {
      for (const auto& [inode, drops] : udpDrops()) {
        const auto before = udpBaseline_.find(inode);
        socket += drops - (before == udpBaseline_.end() ? 0 : before->second);
      }
    }
    last_ = "loopback backlog " + std::to_string(loopback) + ", " +
            (ringDrops_.empty() ? "UDP socket " : "packet socket ") + std::to_string(socket);
    return loopback + socket;
  }

  // Where the last count() found its drops.
  const std::string& describe() const { return last_; }

 private:
  // This process's sockets: inode → a descriptor of it.
  static std::map<std::uint64_t, int> socketFds() {
    std::map<std::uint64_t, int> sockets;
    DIR* dir = ::opendir("/proc/self/fd");
    if (dir == nullptr) return sockets;
    while (const dirent* entry = ::readdir(dir)) {
      char link[64];
      const std::string path = std::string("/proc/self/fd/") + entry->d_name;
      const ssize_t n = ::readlink(path.c_str(), link, sizeof link - 1);
      if (n <= 0) continue;
      const std::string target(link, static_cast<std::size_t>(n));
      if (target.rfind("socket:[", 0) == 0)
        sockets[std::strtoull(target.c_str() + 8, nullptr, 10)] = std::atoi(entry->d_name);
    }
    ::closedir(dir);
    return sockets;
  }

  // The `drops` of this process's IPv4 UDP sockets, by inode.
  static std::map<std::uint64_t, std::uint64_t> udpDrops() {
    std::set<std::uint64_t> mine;
    for (const auto& [inode, fd] : socketFds()) mine.insert(inode);
    std::map<std::uint64_t, std::uint64_t> drops;
    std::ifstream table("/proc/self/net/udp");
    std::string line;
    std::getline(table, line);  // (the header)
    while (std::getline(table, line)) {
      // sl local_address rem_address st tx_queue:rx_queue tr:tm->when retrnsmt uid timeout inode ref pointer drops
      std::istringstream fields(line);
      std::vector<std::string> f;
      for (std::string field; fields >> field;) f.push_back(field);
      if (f.size() < 13) continue;
      const std::uint64_t inode = std::strtoull(f[9].c_str(), nullptr, 10);
      if (mine.count(inode) != 0) drops[inode] = std::strtoull(f[12].c_str(), nullptr, 10);
    }
    return drops;
  }

  // Packets loopback dropped on receiving (the `drop` column of lo's receive side).
  static std::uint64_t loopbackDrops() {
    std::ifstream table("/proc/self/net/dev");
    for (std::string line; std::getline(table, line);) {
      const std::size_t colon = line.find(':');  // ("lo:123": the name is padded, the count is not)
      std::istringstream name(line.substr(0, colon == std::string::npos ? 0 : colon));
      std::string interface;
      if (!(name >> interface) || interface != "lo") continue;
      std::istringstream fields(line.substr(colon + 1));
      std::uint64_t bytes = 0, packets = 0, errors = 0, dropped = 0;
      fields >> bytes >> packets >> errors >> dropped;
      return dropped;
    }
    return 0;
  }

  std::uint64_t loopbackBaseline_;
  std::map<std::uint64_t, std::uint64_t> udpBaseline_;
  std::map<std::uint64_t, std::uint64_t> ringDrops_;  // summed over reads (each read resets the socket's count)
  std::string last_;
};

}  // namespace lfi::testing_support
