#include "tools/viewer/web_server.hpp"

#include <chrono>
#include <fstream>
#include <mutex>
#include <optional>
#include <sstream>
#include <stdexcept>
#include <string_view>
#include <thread>
#include <unordered_set>
#include <utility>

#include <fmt/format.h>
#include <boost/asio/io_context.hpp>
#include <boost/asio/ip/tcp.hpp>
#include <boost/asio/steady_timer.hpp>
#include <boost/beast/core.hpp>
#include <boost/beast/http.hpp>
#include <boost/beast/websocket.hpp>

namespace fieldline::viewer {

namespace asio = boost::asio;
namespace beast = boost::beast;
namespace http = beast::http;
namespace websocket = beast::websocket;
using tcp = asio::ip::tcp;

namespace {

// Requests are small (no bodies are accepted); anything bigger is not a browser asking for a page.
constexpr std::uint32_t kHeaderLimitBytes = 8 * 1024;
constexpr std::uint64_t kBodyLimitBytes = 1024;
constexpr std::size_t kWebSocketReadLimitBytes = 1024;
constexpr auto kHttpIdleTimeout = std::chrono::seconds(30);

class WebSocketSession;

// N of a query "robot=N" (1..99), else 0.
int cameraRobot(const std::string& query) {
  constexpr std::string_view kKey = "robot=";
  if (query.size() <= kKey.size() || query.size() > kKey.size() + 2 ||
      query.compare(0, kKey.size(), kKey) != 0) {
    return 0;
  }
  int robot = 0;
  for (std::size_t i = kKey.size(); i < query.size(); ++i) {
    if (query[i] < '0' || query[i] > '9') return 0;
    robot = robot * 10 + (query[i] - '0');
  }
  return robot;
}

}  // namespace

// Sessions refer to the Impl by plain pointer: it outlives them, because the io_context, which
// owns every pending handler (and through them every session), is destroyed first.
struct WebServer::Impl {
  WebServerOptions options;
  std::string field_json;

  std::mutex latest_mutex;
  std::shared_ptr<const std::string> latest = std::make_shared<const std::string>("{}");
  int camera_robot = 0;  // whose camera `camera` is (under latest_mutex)
  std::shared_ptr<const std::string> camera;
  // The robot of the last /camera.json request and when it came (steady clock ticks).
  std::atomic<int> camera_wanted{0};
  std::atomic<std::int64_t> camera_wanted_at{0};
  // When the last request came (steady clock ticks).
  std::atomic<std::int64_t> last_request_at{0};

  // Touched on the server thread only.
  std::unordered_set<WebSocketSession*> sockets;
  bool pushing = false;  // the push timer is running
  std::atomic<int> connections{0};
  std::atomic<int> web_socket_clients{0};
  std::atomic<std::int64_t> methods_refused{0};
  std::atomic<std::int64_t> connections_refused{0};

  // Declared after what the sessions touch, so destroyed before it.
  asio::io_context io{1};
  tcp::acceptor acceptor{io};
  asio::steady_timer push_timer{io};
  std::thread thread;

  std::shared_ptr<const std::string> snapshot() {
    std::lock_guard lock(latest_mutex);
    return latest;
  }
  // The camera document of `robot`: the latest one when it is that robot's, else one saying
  // that there is no frame (yet). Notes the request: the bus side encodes this robot's frames.
  std::string cameraFor(int robot) {
    camera_wanted_at = std::chrono::steady_clock::now().time_since_epoch().count();
    camera_wanted = robot;
    std::lock_guard lock(latest_mutex);
    if (camera && camera_robot == robot) return *camera;
    return fmt::format("{{\"robot\":{},\"frame\":null,\"lines\":null,\"ball\":null}}", robot);
  }
  std::mutex route_mutex;
  Route route;
  Route currentRoute() {
    std::lock_guard lock(route_mutex);
    return route;
  }
  std::optional<std::string> readWebFile(const std::string& name) const {
    std::ifstream in(options.web_dir / name, std::ios::binary);
    if (!in) return std::nullopt;
    std::ostringstream text;
    text << in.rdbuf();
    return text.str();
  }
  void accept();
  void schedulePush();
};

namespace {

// The path of a request target and its query (after '?', without it).
std::pair<std::string, std::string> splitTarget(std::string target) {
  std::string query;
  if (const auto q = target.find('?'); q != std::string::npos) {
    query = target.substr(q + 1);
    target.resize(q);
  }
  return {std::move(target), std::move(query)};
}

// What a GET gets: 200 with `body` of content type `type`, or an error status with its text.
struct Answer {
  http::status status = http::status::ok;
  std::string body;
  std::string type;
};

// A file of the page's directory; 500 when it is missing (an installation without the page).
Answer webFile(const WebServer::Impl& server, const std::string& target, const std::string& name,
               std::string type) {
  if (auto body = server.readWebFile(name))
    return {http::status::ok, std::move(*body), std::move(type)};
  return {http::status::internal_server_error,
          fmt::format("{} not found under {}\n", target, server.options.web_dir.string())};
}

// The answer of the route set with WebServer::setRoute(): nothing is 404, a std::invalid_argument
// thrown is 400 with its text.
Answer routed(const Route& route, const std::string& target, const std::string& query) {
  std::optional<RouteReply> reply;
  try {
    reply = route(target, query);
  } catch (const std::invalid_argument& e) {
    return {http::status::bad_request, std::string(e.what()) + "\n"};
  }
  if (!reply) return {http::status::not_found, "not found\n"};
  return {http::status::ok, std::move(reply->body), std::move(reply->content_type)};
}

// The answer to GET `target` (a path) with `query`: the server's own pages, else its route's.
Answer answerGet(WebServer::Impl& server, const std::string& target, const std::string& query) {
  if (target == "/" || target == "/index.html")
    return webFile(server, target, "index.html", "text/html; charset=utf-8");
  if (target == "/viewer.js")
    return webFile(server, target, "viewer.js", "text/javascript; charset=utf-8");
  if (target == "/field.json") return {http::status::ok, server.field_json, "application/json"};
  if (target == "/state.json") return {http::status::ok, *server.snapshot(), "application/json"};
  if (target == "/camera.json") {
    const int robot = cameraRobot(query);
    if (robot == 0) return {http::status::bad_request, "camera.json needs ?robot=N (1..99)\n"};
    return {http::status::ok, server.cameraFor(robot), "application/json"};
  }
  if (const Route route = server.currentRoute()) return routed(route, target, query);
  return {http::status::not_found, "not found\n"};
}

// Counts a live connection for as long as the session holding it exists.
class ConnectionSlot {
 public:
  explicit ConnectionSlot(WebServer::Impl& server) : server_(server) { ++server_.connections; }
  ~ConnectionSlot() { --server_.connections; }
  ConnectionSlot(const ConnectionSlot&) = delete;
  ConnectionSlot& operator=(const ConnectionSlot&) = delete;
  WebServer::Impl& server() const { return server_; }

 private:
  WebServer::Impl& server_;
};

class WebSocketSession : public std::enable_shared_from_this<WebSocketSession> {
 public:
  WebSocketSession(tcp::socket socket, std::unique_ptr<ConnectionSlot> slot)
      : ws_(std::move(socket)), slot_(std::move(slot)) {}
  ~WebSocketSession() {
    if (registered_) {
      slot_->server().sockets.erase(this);
      --slot_->server().web_socket_clients;
    }
  }

  void run(http::request<http::string_body> request) {
    ws_.set_option(websocket::stream_base::timeout::suggested(beast::role_type::server));
    ws_.read_message_max(kWebSocketReadLimitBytes);
    ws_.text(true);
    ws_.async_accept(request, [self = shared_from_this()](beast::error_code ec) {
      if (ec) return;
      self->registered_ = true;
      self->slot_->server().sockets.insert(self.get());
      ++self->slot_->server().web_socket_clients;
      if (!self->slot_->server().pushing) self->slot_->server().schedulePush();
      self->push(self->slot_->server().snapshot());
      self->read();
    });
  }

  // Sends `state` now, or after the write in flight (replacing any state waiting before it).
  void push(std::shared_ptr<const std::string> state) {
    if (writing_) {
      pending_ = std::move(state);
      return;
    }
    writing_ = true;
    sending_ = std::move(state);
    ws_.async_write(asio::buffer(*sending_),
                    [self = shared_from_this()](beast::error_code ec, std::size_t) {
                      self->writing_ = false;
                      self->sending_.reset();
                      if (ec) return;
                      if (self->pending_) self->push(std::exchange(self->pending_, nullptr));
                    });
  }

 private:
  // The page sends nothing; reading keeps pings, pongs and the close handshake going and notices
  // a closed connection.
  void read() {
    ws_.async_read(buffer_, [self = shared_from_this()](beast::error_code ec, std::size_t) {
      if (ec) return;
      self->buffer_.clear();
      self->read();
    });
  }

  websocket::stream<beast::tcp_stream> ws_;
  std::unique_ptr<ConnectionSlot> slot_;
  beast::flat_buffer buffer_;
  bool registered_ = false;
  bool writing_ = false;
  std::shared_ptr<const std::string> sending_;
  std::shared_ptr<const std::string> pending_;
};

class HttpSession : public std::enable_shared_from_this<HttpSession> {
 public:
  HttpSession(tcp::socket socket, std::unique_ptr<ConnectionSlot> slot)
      : stream_(std::move(socket)), slot_(std::move(slot)) {}

  void read() {
    parser_.emplace();
    parser_->header_limit(kHeaderLimitBytes);
    parser_->body_limit(kBodyLimitBytes);
    stream_.expires_after(kHttpIdleTimeout);
    http::async_read(
        stream_, buffer_, *parser_, [self = shared_from_this()](beast::error_code ec, std::size_t) {
          if (ec) {
            // A request too big to read still gets an answer before the close.
            if (ec == http::error::body_limit || ec == http::error::header_limit)
              self->sendError(http::status::payload_too_large, "request too large\n", 11, false);
            else
              self->close();
            return;
          }
          self->handle(self->parser_->release());
        });
  }

 private:
  void handle(http::request<http::string_body> request) {
    WebServer::Impl& server = slot_->server();
    server.last_request_at = std::chrono::steady_clock::now().time_since_epoch().count();
    const unsigned version = request.version();
    const bool keep_alive = request.keep_alive();
    if (request.method() != http::verb::get) {
      ++server.methods_refused;
      sendError(http::status::method_not_allowed, "read-only: only GET is served\n", version,
                keep_alive);
      return;
    }
    auto [target, query] = splitTarget(std::string(request.target()));
    if (websocket::is_upgrade(request)) {
      upgradeToWebSocket(std::move(request), target);
      return;
    }
    Answer answer = answerGet(server, target, query);
    if (answer.status != http::status::ok) {
      sendError(answer.status, std::move(answer.body), version, keep_alive);
      return;
    }
    sendPage(std::move(answer), version, keep_alive);
  }

  // Hands the connection to a WebSocketSession (this session ends); only /ws is one.
  void upgradeToWebSocket(http::request<http::string_body> request, const std::string& target) {
    if (target != "/ws") {
      sendError(http::status::not_found, "the WebSocket is at /ws\n", request.version(), false);
      return;
    }
    stream_.expires_never();
    std::make_shared<WebSocketSession>(stream_.release_socket(), std::move(slot_))
        ->run(std::move(request));
  }

  void sendPage(Answer answer, unsigned version, bool keep_alive) {
    auto response = std::make_shared<http::response<http::string_body>>(http::status::ok, version);
    response->set(http::field::content_type, answer.type);
    response->set(http::field::cache_control, "no-store");
    response->keep_alive(keep_alive);
    response->body() = std::move(answer.body);
    response->prepare_payload();
    send(std::move(response));
  }

  void sendError(http::status status, std::string text, unsigned version, bool keep_alive) {
    auto response = std::make_shared<http::response<http::string_body>>(status, version);
    response->set(http::field::content_type, "text/plain; charset=utf-8");
    if (status == http::status::method_not_allowed) response->set(http::field::allow, "GET");
    response->keep_alive(keep_alive);
    response->body() = std::move(text);
    response->prepare_payload();
    send(std::move(response));
  }

  void send(std::shared_ptr<http::response<http::string_body>> response) {
    http::async_write(stream_, *response,
                      [self = shared_from_this(), response](beast::error_code ec, std::size_t) {
                        if (ec || response->need_eof()) {
                          self->close();
                          return;
                        }
                        self->read();
                      });
  }

  void close() {
    beast::error_code ignored;
    stream_.socket().shutdown(tcp::socket::shutdown_send, ignored);
  }

  beast::tcp_stream stream_;
  std::unique_ptr<ConnectionSlot> slot_;
  beast::flat_buffer buffer_;
  std::optional<http::request_parser<http::string_body>> parser_;
};

}  // namespace

void WebServer::Impl::accept() {
  acceptor.async_accept([self = this](beast::error_code ec, tcp::socket socket) {
    if (ec == asio::error::operation_aborted) return;
    if (!ec) {
      if (self->connections.load() >= self->options.max_connections) {
        ++self->connections_refused;
        beast::error_code ignored;
        socket.close(ignored);
      } else {
        std::make_shared<HttpSession>(std::move(socket), std::make_unique<ConnectionSlot>(*self))
            ->read();
      }
    }
    self->accept();
  });
}

void WebServer::Impl::schedulePush() {
  pushing = true;
  push_timer.expires_after(std::chrono::duration_cast<asio::steady_timer::duration>(
      std::chrono::duration<double>(options.push_period_s)));
  push_timer.async_wait([self = this](beast::error_code ec) {
    if (ec) return;
    // Without WebSocket clients the timer stops (the next one to connect starts it): an
    // unwatched viewer's server thread sleeps.
    if (self->sockets.empty()) {
      self->pushing = false;
      return;
    }
    const auto state = self->snapshot();
    for (WebSocketSession* session : self->sockets)
      session->push(state);
    self->schedulePush();
  });
}

WebServer::WebServer(WebServerOptions options, std::string field_json)
    : impl_(std::make_unique<Impl>()) {
  impl_->options = std::move(options);
  impl_->field_json = std::move(field_json);
  const std::string where = fmt::format("{}:{}", impl_->options.address, impl_->options.port);
  try {
    const tcp::endpoint endpoint(asio::ip::make_address(impl_->options.address),
                                 impl_->options.port);
    impl_->acceptor.open(endpoint.protocol());
    impl_->acceptor.set_option(asio::socket_base::reuse_address(true));
    impl_->acceptor.bind(endpoint);
    impl_->acceptor.listen(asio::socket_base::max_listen_connections);
  } catch (const boost::system::system_error& e) {
    throw std::runtime_error(fmt::format("cannot listen on {}: {}", where, e.what()));
  }
  impl_->accept();
  impl_->thread = std::thread([impl = impl_.get()] { impl->io.run(); });
}

WebServer::~WebServer() {
  impl_->io.stop();
  if (impl_->thread.joinable()) impl_->thread.join();
}

void WebServer::publish(std::string state_json) {
  auto state = std::make_shared<const std::string>(std::move(state_json));
  std::lock_guard lock(impl_->latest_mutex);
  impl_->latest = std::move(state);
}

void WebServer::publishCamera(int robot, std::string camera_json) {
  auto camera = std::make_shared<const std::string>(std::move(camera_json));
  std::lock_guard lock(impl_->latest_mutex);
  impl_->camera = std::move(camera);
  impl_->camera_robot = robot;
}

void WebServer::setRoute(Route route) {
  std::lock_guard lock(impl_->route_mutex);
  impl_->route = std::move(route);
}

int WebServer::cameraWanted(double within_s) const {
  const int robot = impl_->camera_wanted.load();
  if (robot == 0) return 0;
  const std::chrono::steady_clock::duration at(impl_->camera_wanted_at.load());
  const auto age = std::chrono::steady_clock::now().time_since_epoch() - at;
  return age <= std::chrono::duration<double>(within_s) ? robot : 0;
}

bool WebServer::watched(double within_s) const {
  if (impl_->web_socket_clients.load() > 0) return true;
  const std::int64_t at = impl_->last_request_at.load();
  if (at == 0) return false;
  const auto age =
      std::chrono::steady_clock::now().time_since_epoch() - std::chrono::steady_clock::duration(at);
  return age <= std::chrono::duration<double>(within_s);
}

unsigned short WebServer::port() const {
  return impl_->acceptor.local_endpoint().port();
}
int WebServer::webSocketClients() const {
  return impl_->web_socket_clients.load();
}
std::int64_t WebServer::methodsRefused() const {
  return impl_->methods_refused.load();
}
std::int64_t WebServer::connectionsRefused() const {
  return impl_->connections_refused.load();
}

}  // namespace fieldline::viewer
