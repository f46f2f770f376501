// One asio::io_context run on a thread of its own, as vgrd's I/O thread: objects that
// live on it (RobotServer, ResultStore) are created on the test thread before start() and
// touched afterwards only through run(f), which posts f and waits for it. stop() (also
// the destructor) lets the thread finish: work guard released, io_context stopped, joined.
#pragma once

#include <functional>
#include <thread>

#include <boost/asio/executor_work_guard.hpp>
#include <boost/asio/io_context.hpp>

namespace vgr::test {

class IoThread {
 public:
  IoThread() = default;
  ~IoThread() { stop(); }
  IoThread(const IoThread&) = delete;
  IoThread& operator=(const IoThread&) = delete;

  boost::asio::io_context& io() { return io_; }
  void start();
  // Runs f on the I/O thread and waits for it (only after start()).
  void run(const std::function<void()>& f);
  void stop();

 private:
  boost::asio::io_context io_;
  boost::asio::executor_work_guard<boost::asio::io_context::executor_type> work_ = boost::asio::make_work_guard(io_);
  std::thread thread_;
};

}  // namespace vgr::test
