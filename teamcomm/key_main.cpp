// fieldline-team-key: makes a new team key file for the team packet MAC.
#include <sys/stat.h>

#include <fstream>
#include <iostream>

#include "common/cli/cli.hpp"
#include "teamcomm/team_key.hpp"

using namespace fieldline;

int main(int argc, char** argv) {
  cli::App app{
      "Writes a new random 32-byte team key (64 hex digits) for the team packet MAC. Copy the "
      "same file to every robot of the team and name it in config/team/*.yaml (key_file)."};
  std::string out;
  bool force = false;
  app.add_option("--out", out, "Key file to write (readable by its owner only)")->required();
  app.add_flag("--force", force, "Overwrite an existing file");
  try {
    app.parse(argc, argv);
  } catch (const cli::ParseError& e) {
    return app.exit(e) == 0 ? 0 : 2;
  }
  if (!force && std::ifstream(out)) {
    std::cerr << out << " exists; pass --force to overwrite it\n";
    return 2;
  }
  try {
    const teamcomm::TeamKey key = teamcomm::generateTeamKey();
    std::ofstream file(out, std::ios::trunc);
    file << teamcomm::formatTeamKey(
        key, "fieldline team key (keep it secret; same file on every robot)");
    file.close();
    if (!file) {
      std::cerr << "cannot write " << out << "\n";
      return 1;
    }
    ::chmod(out.c_str(), 0600);
  } catch (const std::exception& e) {
    std::cerr << e.what() << "\n";
    return 1;
  }
  std::cout << "wrote " << out << "\n";
  return 0;
}
