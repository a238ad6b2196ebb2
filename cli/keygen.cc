// `dome keygen OUT_PREFIX [--role ROLE...]`: a CURVE key pair for the runtime's
// sockets (net/security.h): OUT_PREFIX.key, the secret key (mode 0600, stays on its
// machine), and OUT_PREFIX.pub, the public key followed by its roles (the line the
// master's allow-list takes), or alone for the master's own key (to every worker and
// client). Existing files are never overwritten.
#include <cstdio>
#include <memory>
#include <string>
#include <vector>

#include "cli/commands.h"
#include "net/security.h"

namespace dome::cli {

void AddKeygenCommand(CLI::App* app, int* exit_code) {
  auto* cmd = app->add_subcommand(
      "keygen", "Make a CURVE key pair: OUT_PREFIX.key (secret, 0600) and OUT_PREFIX.pub");
  auto prefix = std::make_shared<std::string>();
  auto roles = std::make_shared<std::vector<std::string>>();
  cmd->add_option("OUT_PREFIX", *prefix, "path without extension, e.g. /etc/dome/keys/master")
      ->required();
  cmd->add_option("--role", *roles,
                  "what the key may do on the master, written after the key in OUT_PREFIX.pub: "
                  "worker, client or capture (repeat for several); none for the master's key")
      ->check(CLI::IsMember({net::kRoleWorker, net::kRoleClient, net::kRoleCapture}));
  cmd->callback([=] {
    const net::KeyPair keys = net::GenerateKeyPair();
    std::string role_list;
    for (const auto& r : *roles) role_list += (role_list.empty() ? "" : ",") + r;
    net::WriteKeyPair(*prefix, keys, role_list);
    std::printf("secret key %s.key (keep it on this machine)\npublic key %s.pub: %s\n",
                prefix->c_str(), prefix->c_str(), keys.public_key.c_str());
    *exit_code = 0;
  });
}

}  // namespace dome::cli
