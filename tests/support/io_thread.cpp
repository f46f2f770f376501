#include "tests/support/io_thread.hpp"

#include <future>

#include <boost/asio/post.hpp>

namespace vgr::test {

void IoThread::start() {
  thread_ = std::thread([this] { io_.run(); });
}

void IoThread::run(const std::function<void()>& f) {
  std::promise<void> done;
  boost::asio::post(io_, [&] {
    f();
    done.set_value();
  });
  done.get_future().wait();
}

void IoThread::stop() {
  work_.reset();
  io_.stop();
  if (thread_.joinable()) thread_.join();
}

}  // namespace vgr::test
