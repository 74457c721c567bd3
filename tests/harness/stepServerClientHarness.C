/*---------------------------------------------------------------------------*\
    A command-line driver of the plugin's plain C++ client (stepServerClient,
    adapter/foam/plugin/client/), for tests/test_client_wire.py:
    the test compiles it with the client's four sources and runs it against a
    fake step-server that sends hand-built frames (docs/protocol.md).

    Usage:
        stepServerClientHarness ENDPOINT [--reply-timeout S] STEP...
    ENDPOINT: tcp:PORT (on 127.0.0.1) or a UNIX socket path. STEPs, run in
    order after connect():
        hello NRANKS TOKEN X,Y,Z,...     (the coordinates of every point)
        request T PX PY PZ VX VY VZ MPX MPY MPZ MVX MVY MVZ
        write T
        bye
    Reals are read with strtod (decimal, hex floats such as 0x1.8p-3, nan).
    One line per reply, reals in C99 hex (%a, exact):
        WELCOME nPoints maxMappingDistance internalStep
        FRAME ux uy uz ax ay az
        DISPLACEMENT nValues d0 d1 ...
        ACK
        BYE
    A stepServerError prints "stepServerError: <what()>" and exits 3.
\*---------------------------------------------------------------------------*/

#include "stepServerClient.H"

#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <sstream>
#include <string>
#include <vector>

namespace
{

double real(const char* s)
{
    char* end = nullptr;
    const double d = std::strtod(s, &end);
    if (end == s || *end)
    {
        std::fprintf(stderr, "harness: not a real: '%s'\n", s);
        std::exit(2);
    }
    return d;
}


std::vector<double> reals(const std::string& csv)
{
    std::vector<double> v;
    std::stringstream ss(csv);
    std::string item;
    while (std::getline(ss, item, ','))
    {
        v.push_back(real(item.c_str()));
    }
    return v;
}


void need(int i, int n, int argc, const char* step)
{
    if (i + n >= argc)
    {
        std::fprintf(stderr, "harness: '%s' needs %d arguments\n", step, n);
        std::exit(2);
    }
}

} // End anonymous namespace


int main(int argc, char* argv[])
{
    if (argc < 2)
    {
        std::fprintf(stderr, "usage: %s SOCKET|tcp:PORT|file:ENDPOINT_FILE"
                     " [--reply-timeout S] STEP...\n", argv[0]);
        return 2;
    }
    stepServer::Endpoint ep;
    const std::string where(argv[1]);
    if (where.compare(0, 4, "tcp:") == 0)
    {
        ep.port = std::atoi(where.c_str() + 4);
    }
    else if (where.compare(0, 5, "file:") == 0)
    {
        ep.endpointFile = where.substr(5);
    }
    else
    {
        ep.socketPath = where;
    }
    ep.connectTimeout = 5;
    ep.replyTimeout = 10;

    int i = 2;
    if (i + 1 < argc && std::strcmp(argv[i], "--reply-timeout") == 0)
    {
        ep.replyTimeout = real(argv[i + 1]);
        i += 2;
    }

    stepServer::stepServerClient client(ep);
    try
    {
        client.connect();
        for (; i < argc; ++i)
        {
            const std::string step(argv[i]);
            if (step == "hello")
            {
                need(i, 3, argc, "hello");
                const auto nRanks = std::uint32_t(std::strtoul(argv[i + 1], nullptr, 10));
                const stepServer::Welcome w =
                    client.hello(nRanks, argv[i + 2], reals(argv[i + 3]));
                std::printf("WELCOME %u %a %a\n", unsigned(w.nPoints),
                            w.maxMappingDistance, w.internalStep);
                i += 3;
            }
            else if (step == "request")
            {
                need(i, 13, argc, "request");
                const double t = real(argv[i + 1]);
                stepServer::Loads loads;
                for (int k = 0; k < 3; ++k)
                {
                    loads.pressureForce[k] = real(argv[i + 2 + k]);
                    loads.viscousForce[k] = real(argv[i + 5 + k]);
                    loads.pressureMoment[k] = real(argv[i + 8 + k]);
                    loads.viscousMoment[k] = real(argv[i + 11 + k]);
                }
                const stepServer::Displacement r = client.request(t, loads);
                std::printf("FRAME");
                for (double x : r.frameVelocity) std::printf(" %a", x);
                for (double x : r.frameAcceleration) std::printf(" %a", x);
                std::printf("\nDISPLACEMENT %zu", r.d.size());
                for (double x : r.d) std::printf(" %a", x);
                std::printf("\n");
                i += 13;
            }
            else if (step == "write")
            {
                need(i, 1, argc, "write");
                client.write(real(argv[i + 1]));
                std::printf("ACK\n");
                i += 1;
            }
            else if (step == "bye")
            {
                client.bye();
                std::printf("BYE\n");
            }
            else
            {
                std::fprintf(stderr, "harness: unknown step '%s'\n", step.c_str());
                return 2;
            }
            std::fflush(stdout);
        }
    }
    catch (const stepServer::stepServerError& e)
    {
        std::printf("stepServerError: %s\n", e.what());
        return 3;
    }
    return 0;
}
