/*---------------------------------------------------------------------------*\
    stepServer::Endpoint: its name for messages, and the server's endpoint
    file read into a socket path or a TCP host and port
    (docs/protocol.md, docs/openfoam-plugin.md)
\*---------------------------------------------------------------------------*/

#include "stepServerEndpoint.H"

#include <cstdlib>
#include <fstream>
#include <sstream>

namespace stepServer
{

// * * * * * * * * * * * * * * * * Endpoint  * * * * * * * * * * * * * * * * //

std::string Endpoint::describe() const
{
    if (port > 0)
    {
        std::ostringstream os;
        os << "tcp://"
           << (host.find(':') != std::string::npos ? "[" + host + "]" : host)
           << ':' << port;
        return os.str();
    }
    if (!endpointFile.empty())
    {
        return "the address in " + endpointFile;
    }
    return socketPath;
}


bool Endpoint::resolve(Endpoint& target, std::string& why) const
{
    target = *this;
    if (port > 0 || endpointFile.empty())
    {
        return true;
    }
    // The server's endpoint file: "key value" lines, '#' comments;
    // "host H" + "port P" for TCP, else "unix PATH"
    std::ifstream is(endpointFile);
    if (!is)
    {
        why = "no endpoint file " + endpointFile
            + " (the server writes it "
              "when it is ready)";
        return false;
    }
    std::string line, h, u;
    long p = 0;
    while (std::getline(is, line))
    {
        std::istringstream ls(line);
        std::string key, value;
        if (!(ls >> key >> value) || key[0] == '#') continue;
        if (key == "host")
            h = value;
        else if (key == "port")
            p = std::strtol(value.c_str(), nullptr, 10);
        else if (key == "unix")
            u = value;
    }
    target.endpointFile.clear();
    if (!h.empty() && p > 0 && p < 65536)
    {
        target.host = h;
        target.port = int(p);
        return true;
    }
    if (!u.empty())
    {
        target.port = 0;
        target.socketPath = u;
        return true;
    }
    why = "endpoint file " + endpointFile
        + " names neither host and port "
          "nor a unix socket";
    return false;
}

} // End namespace stepServer
