// module sources
