// The viewer's web side: HTTP for the page, its script, the field and the current state, the
// camera view (GET /camera.json?robot=N), and a WebSocket (/ws) that pushes the latest state to
// every client at a fixed rate. Read-only: any method but GET gets 405, any other path 404.
//
// Runs Boost.Asio on its own thread, so neither slow nor many clients ever block the bus side,
// which only hands over a new JSON text with publish(). A slow client skips states instead of
// queueing them.
#pragma once

#include <atomic>
#include <cstdint>
#include <filesystem>
#include <functional>
#include <memory>
#include <optional>
#include <string>

namespace fieldline::viewer {

struct WebServerOptions {
  // Address to listen on; the default keeps the page on this machine.
  std::string address = "127.0.0.1";
  // 0 picks a free port (tests); port() tells which.
  unsigned short port = 8080;
  // Directory with index.html and viewer.js.
  std::filesystem::path web_dir;
  // Period of the WebSocket push, s.
  double push_period_s = 0.05;
  // Connections (HTTP and WebSocket) served at once; more are closed at once.
  int max_connections = 64;
};

// What a route of WebServer::setRoute() answers to a GET: the body and its content type.
struct RouteReply {
  std::string body;
  std::string content_type = "application/json";
};
// Answers GETs of paths the server has no page of its own for (a recording's playback, the chart
// library): nothing is 404; a std::invalid_argument thrown is 400 with its text. Runs on the
// server thread.
using Route =
    std::function<std::optional<RouteReply>(const std::string& path, const std::string& query)>;

class WebServer {
 public:
  // Binds and listens (throws std::runtime_error naming address and port if it cannot) and
  // starts the server thread.
  WebServer(WebServerOptions options, std::string field_json);
  ~WebServer();
  WebServer(const WebServer&) = delete;
  WebServer& operator=(const WebServer&) = delete;

  // Hands over the latest state document (from any thread).
  void publish(std::string state_json);
  // Hands over the latest camera document, of robot `robot` (from any thread).
  void publishCamera(int robot, std::string camera_json);
  // The robot of the latest GET /camera.json?robot=N if it came within `within_s` seconds, else
  // 0: a page shows that robot's camera.
  int cameraWanted(double within_s) const;
  // Routes further GET paths to `route` (from any thread).
  void setRoute(Route route);

  unsigned short port() const;
  // WebSocket clients connected now.
  int webSocketClients() const;
  // True while a WebSocket client is connected or a GET came within `within_s` seconds: someone
  // watches (the viewer opens the robots' buses only then).
  bool watched(double within_s) const;
  // Requests refused with 405 since start, and connections closed for being over the limit.
  std::int64_t methodsRefused() const;
  std::int64_t connectionsRefused() const;

  struct Impl;

 private:
  std::unique_ptr<Impl> impl_;
};

}  // namespace fieldline::viewer
