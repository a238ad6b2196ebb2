// `dome keygen OUT_PREFIX`: a CURVE key pair for the runtime's sockets
// (net/security.h): OUT_PREFIX.key, the secret key (mode 0600, stays on its machine),
// and OUT_PREFIX.pub, the public key (to the master's allow-list, or to every worker
// and client when it is the master's). Existing files are never overwritten.
#include <cstdio>
#include <memory>
#include <string>

#include "cli/commands.h"
#include "net/security.h"

namespace dome::cli {

void AddKeygenCommand(CLI::App* app, int* exit_code) {
  auto* cmd = app->add_subcommand(
      "keygen", "Make a CURVE key pair: OUT_PREFIX.key (secret, 0600) and OUT_PREFIX.pub");
  auto prefix = std::make_shared<std::string>();
  cmd->add_option("OUT_PREFIX", *prefix, "path without extension, e.g. /etc/dome/keys/master")
      ->required();
  cmd->callback([=] {
    const net::KeyPair keys = net::GenerateKeyPair();
    net::WriteKeyPair(*prefix, keys);
    std::printf("secret key %s.key (keep it on this machine)\npublic key %s.pub: %s\n",
                prefix->c_str(), prefix->c_str(), keys.public_key.c_str());
    *exit_code = 0;
  });
}

}  // namespace dome::cli
