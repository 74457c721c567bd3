/*---------------------------------------------------------------------------*\
    stepServerClient, the messages: the payloads of docs/protocol.md
    (version 2). The frames are in stepServerChannel.C, the socket stream in
    stepServerStream.C, the byte encoding in stepServerWire.H.
\*---------------------------------------------------------------------------*/

#include "stepServerClient.H"
#include "stepServerWire.H"

#include <cmath>
#include <sstream>

namespace stepServer
{

using namespace wire;

// * * * * * * * * * * * * * * * Constructors  * * * * * * * * * * * * * * * //

stepServerClient::stepServerClient(const Endpoint& ep) :
    channel_(ep)
{}


stepServerClient::~stepServerClient()
{
    close();
}


// * * * * * * * * * * * * * * Private helpers  * * * * * * * * * * * * * * //

void stepServerClient::fail(const std::string& msg)
{
    channel_.stream().fail(msg);
}


// * * * * * * * * * * * * * * * Member Functions  * * * * * * * * * * * * * //

void stepServerClient::connect()
{
    channel_.connect();
}


Welcome stepServerClient::hello(
    std::uint32_t nRanks,
    const std::string& token,
    const std::vector<double>& points
)
{
    if (points.size() % 3)
    {
        throw stepServerError("HELLO: point array size not a multiple of 3");
    }
    nPoints_ = points.size() / 3;

    std::vector<unsigned char> p;
    p.reserve(12 + token.size() + 8 * points.size());
    putU32(p, nRanks);
    putU32(p, std::uint32_t(nPoints_));
    putU32(p, std::uint32_t(token.size()));
    p.insert(p.end(), token.begin(), token.end());
    for (double x : points) putF64(p, x);

    const std::uint32_t seq = channel_.sendFrame(HELLO, p);
    const auto r = channel_.recvReply(seq, WELCOME, "HELLO");
    if (r.size() != 20)
    {
        fail(
            "malformed WELCOME: payload of " + std::to_string(r.size())
            + " bytes, expected 20"
        );
    }
    Welcome w;
    w.nPoints = getU32(r.data());
    w.maxMappingDistance = getF64(r.data() + 4);
    w.internalStep = getF64(r.data() + 12);
    if (w.nPoints != nPoints_)
    {
        fail(
            "WELCOME accepted " + std::to_string(w.nPoints)
            + " points, but HELLO sent " + std::to_string(nPoints_)
        );
    }
    return w;
}


std::vector<double> stepServerClient::request(
    double t,
    const std::array<double, 3>& pressureForce,
    const std::array<double, 3>& viscousForce
)
{
    std::vector<unsigned char> p;
    p.reserve(56);
    putF64(p, t);
    for (double f : pressureForce) putF64(p, f);
    for (double f : viscousForce) putF64(p, f);

    const std::uint32_t seq = channel_.sendFrame(REQUEST, p);
    const auto r = channel_.recvReply(seq, DISPLACEMENT, "REQUEST");

    const std::size_t expected = 12 + 24 * nPoints_;
    if (r.size() < 12 || r.size() != expected)
    {
        fail(
            "malformed DISPLACEMENT: payload of " + std::to_string(r.size())
            + " bytes, expected " + std::to_string(expected) + " for "
            + std::to_string(nPoints_) + " points"
        );
    }
    const double rt = getF64(r.data());
    const std::uint32_t n = getU32(r.data() + 8);
    if (n != nPoints_)
    {
        fail(
            "DISPLACEMENT for " + std::to_string(n) + " points, expected "
            + std::to_string(nPoints_)
        );
    }
    if (rt != t)
    {
        std::ostringstream os;
        os.precision(17);
        os << "DISPLACEMENT for time " << rt << ", requested " << t;
        fail(os.str());
    }
    std::vector<double> d(3 * nPoints_);
    for (std::size_t i = 0; i < d.size(); ++i)
    {
        d[i] = getF64(r.data() + 12 + 8 * i);
        if (!std::isfinite(d[i]))
        {
            fail(
                "DISPLACEMENT contains a non-finite value at point "
                + std::to_string(i / 3)
            );
        }
    }
    return d;
}


void stepServerClient::write(double t)
{
    std::vector<unsigned char> p;
    putF64(p, t);
    const std::uint32_t seq = channel_.sendFrame(WRITE, p);
    const auto r = channel_.recvReply(seq, ACK, "WRITE");
    if (!r.empty())
    {
        fail(
            "malformed ACK: payload of " + std::to_string(r.size())
            + " bytes, expected 0"
        );
    }
}


void stepServerClient::bye() noexcept
{
    if (!connected()) return;
    try
    {
        channel_.sendFrame(BYE, {});
    }
    catch (...)
    {}
    close();
}


void stepServerClient::close() noexcept
{
    channel_.stream().close();
}

} // End namespace stepServer
